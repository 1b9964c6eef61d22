"""``somite campaign pack`` / ``unpack``, and a run's physics version: a campaign stopped
part-way, packed, unpacked elsewhere and finished there is the campaign never interrupted; a
run (or campaign) of another physics resumes only when forced, and says so."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from somite.campaigns import directory as campaign_dir
from somite.campaigns.expansion import expand
from somite.campaigns.pack import EVERY, LAST
from somite.campaigns.spec import load
from somite.campaigns.work import run_config, run_task
from somite.cli import main
from somite.experiments.history import THINNED
from somite.experiments.runner import evolve
from somite.sim.version import PHYSICS

SPEC = """
[defaults]
generations = 24
population = 4
duration = 1.0
checkpoint_every = 4
validate_every = 12
[experiments.rq1]
kind = "evolve"
shapes = ["worm"]
seeds = [0, 1, 2]
"""
STOPPED_AT = 17
"""The generation after which the second run is stopped (its last checkpoint is at 16)."""


class Stop(Exception):
    pass


def _stop_at(generation: int):
    def progress(ea, row):
        if ea.generation == generation:
            raise Stop
    return progress


def _campaign(root: Path, spec: Path) -> tuple[Path, dict]:
    campaign = load(spec)
    doc = campaign_dir.prepare(root, campaign_dir.document(campaign, expand(campaign)),
                               resume=False)
    return root, doc


@pytest.fixture(scope="module")
def spec(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "tiny.toml"
    path.write_text(SPEC)
    return path


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory, spec) -> Path:
    """The campaign run through, each task as a worker runs it."""
    root, doc = _campaign(tmp_path_factory.mktemp("whole") / "c", spec)
    for task in doc["tasks"]:
        run_task(str(root), task)
    return root


@pytest.fixture(scope="module")
def stopped(tmp_path_factory, spec) -> Path:
    """The campaign stopped part-way: s0 finished, s1 stopped after generation 17 (log rows
    past its checkpoint), s2 not started."""
    root, doc = _campaign(tmp_path_factory.mktemp("stopped") / "c", spec)
    first, second, _ = doc["tasks"]
    run_task(str(root), first)
    with pytest.raises(Stop):
        evolve(run_config(second["options"]), root / second["path"],
               progress=_stop_at(STOPPED_AT))
    return root


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _without_elapsed(name: str, data: bytes):
    """A file's content as compared between two machines' runs: the wall-clock times of
    log.csv and checkpoint.json aside (the one thing not sealed, nor the same twice)."""
    if name.endswith("log.csv"):
        rows = [line.split(",") for line in data.decode().splitlines()]
        at = rows[0].index("elapsed_seconds")
        return [row[:at] + row[at + 1:] for row in rows]
    if name.endswith("checkpoint.json"):
        state = json.loads(data)
        state.pop("elapsed_seconds")
        return state
    return data


def _same_bests(thinned: bytes, whole: bytes) -> int:
    """Every line of ``thinned`` is ``whole``'s line, or a thinned line standing for it (its
    generation and digest); returns how many were thinned."""
    ours, theirs = thinned.decode().splitlines(), whole.decode().splitlines()
    assert len(ours) == len(theirs)
    count = 0
    for generation, (line, full) in enumerate(zip(ours, theirs)):
        match = THINNED.fullmatch(line)
        if match is None:
            assert line == full, generation
            continue
        count += 1
        assert int(match[1]) == generation
        assert match[2] == hashlib.sha256(full.encode()).hexdigest()[:8]
    return count


def test_a_campaign_packed_part_way_and_finished_elsewhere_is_the_uninterrupted_one(
        stopped, uninterrupted, tmp_path, capsys):
    packed = tmp_path / "tiny.pack"
    assert main(["campaign", "pack", str(stopped), "--out", str(packed)]) == 0
    out, err = capsys.readouterr()
    assert "reading rq1/worm-s0 (1 of 3 tasks)" in err and f"{packed}:" in out
    assert "reading rq1/worm-s1 (2 of 3 tasks)" in err  # stopped part-way: no done.json
    moved = tmp_path / "elsewhere" / "c"
    assert main(["campaign", "unpack", str(packed), "--out", str(moved)]) == 0
    assert f"campaign run --resume --out {moved}" in capsys.readouterr().out

    # Unpacked, every file is as it was (no lock, no temporary file), but the bests that
    # were thinned: every EVERY-th generation's and the last LAST's are kept.
    before, after = _files(stopped), _files(moved)
    assert set(after) == set(before)
    for name, data in before.items():
        if name.endswith("bests.jsonl"):
            lines = after[name].decode().splitlines()
            kept = {g for g in range(len(lines)) if g % EVERY == 0 or g >= len(lines) - LAST}
            assert _same_bests(after[name], data) == len(lines) - len(kept)
            assert all(bool(THINNED.fullmatch(line)) != (g in kept)
                       for g, line in enumerate(lines))
        else:
            assert after[name] == data, name

    # Finished there by `campaign run --resume`, as a user would.
    assert main(["campaign", "run", "--resume", "--out", str(moved), "--workers", "1",
                 "--quiet"]) == 0, capsys.readouterr().err
    finished, whole = _files(moved), _files(uninterrupted)
    assert set(finished) == set(whole)
    thinned = 0
    for name, data in whole.items():
        if name.endswith("done.json"):  # elapsed and finished times
            continue
        if name.endswith("bests.jsonl"):
            thinned += _same_bests(finished[name], data)
        else:
            assert _without_elapsed(name, finished[name]) == _without_elapsed(name, data), name
    # s0 was packed finished (25 lines: 13 thinned), s1 at 18 lines (7 thinned); s2 whole.
    assert thinned == 13 + 7


def _one_line(capsys, argv) -> str:
    capsys.readouterr()  # what commands before it printed
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    return err


def test_bad_packs_and_folders_are_one_line_errors(tmp_path, capsys, spec):
    root, _ = _campaign(tmp_path / "c", spec)
    assert "campaign=" in _one_line(capsys, ["campaign", "pack", str(tmp_path),
                                             "--out", str(tmp_path / "p")])
    assert "out=" in _one_line(capsys, ["campaign", "pack", str(root), "--out",
                                        str(root / "inside.pack")])
    packed = tmp_path / "c.pack"
    assert main(["campaign", "pack", str(root), "--out", str(packed), "--quiet"]) == 0
    assert not list(tmp_path.glob(".c.pack.*"))  # written through a temporary file
    assert "not a somite campaign pack" in _one_line(
        capsys, ["campaign", "unpack", str(spec), "--out", str(tmp_path / "u")])
    damaged = tmp_path / "damaged.pack"
    data = bytearray(packed.read_bytes())
    data[len(data) // 2] ^= 0xFF
    damaged.write_bytes(bytes(data))
    assert "damaged pack" in _one_line(capsys, ["campaign", "unpack", str(damaged), "--out",
                                                str(tmp_path / "u")])
    assert not (tmp_path / "u").exists() and not list(tmp_path.glob(".u.unpack.*"))
    assert "not empty" in _one_line(capsys, ["campaign", "unpack", str(packed), "--out",
                                             str(root)])
    assert main(["campaign", "unpack", str(packed), "--out", str(tmp_path / "u"), "--quiet"]) == 0
    assert _files(tmp_path / "u") == _files(root)


# -- physics ------------------------------------------------------------------------------------

def _set_physics(run: Path, version: str | None) -> None:
    path = run / "physics.json"
    if version is None:
        path.unlink()
        return
    data = json.loads(path.read_text())
    data["started"] = version
    path.write_text(json.dumps(data))


def test_a_run_records_its_physics_and_another_resumes_only_when_forced(made_run, tmp_path,
                                                                         capsys):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(made_run, run)
    assert json.loads((run / "physics.json").read_text())["started"] == PHYSICS
    assert "physics.json" in json.loads((run / "manifest.json").read_text())["files"]
    _set_physics(run, "somite-physics-0")
    before = _files(run)
    resume = ["evolve", "--resume", "--out", str(run), "--generations", "2", "--quiet"]
    err = _one_line(capsys, resume)
    assert "'somite-physics-0'" in err and repr(PHYSICS) in err and "--force-physics" in err
    assert _files(run) == before  # refused before any file is touched
    assert main([*resume, "--force-physics"]) == 0
    record = json.loads((run / "physics.json").read_text())
    assert record["started"] == "somite-physics-0"
    assert record["forced"] == [{"generation": 1, "from": "somite-physics-0",
                                 "physics": PHYSICS}]
    assert len((run / "log.csv").read_text().splitlines()) == 1 + 3
    # Now a run of this physics: resumed without the flag, and nothing more recorded.
    assert main(["evolve", "--resume", "--out", str(run), "--generations", "3", "--quiet"]) == 0
    assert json.loads((run / "physics.json").read_text()) == record
    # A run of a somite before physics versions is refused too.
    _set_physics(run, None)
    assert "did not record" in _one_line(capsys, ["evolve", "--resume", "--out", str(run),
                                              "--generations", "4", "--quiet"])
    assert "only with --resume" in _one_line(
        capsys, ["evolve", "--out", str(tmp_path / "new"), "--force-physics", "--quiet"])


def test_a_campaign_of_another_physics_resumes_only_when_forced(stopped, tmp_path, capsys):
    import shutil

    from somite.commands.campaign import _force_physics

    root = tmp_path / "c"
    shutil.copytree(stopped, root)
    run = root / "rq1" / "worm-s1"
    _set_physics(run, "somite-physics-0")
    before = _files(root)
    err = _one_line(capsys, ["campaign", "run", "--resume", "--out", str(root), "--quiet"])
    assert "'somite-physics-0'" in err and repr(PHYSICS) in err and str(run) in err
    assert _files(root) == before
    # --force-physics records the forced resume in the run's physics.json, then the workers
    # resume it as a run of this physics (here, the task run as a worker runs it).
    doc = campaign_dir.read(root)
    _force_physics(root, doc, True)
    task = next(t for t in doc["tasks"] if t["path"] == "rq1/worm-s1")
    run_task(str(root), task)
    record = json.loads((run / "physics.json").read_text())
    assert record["forced"] == [{"generation": 16, "from": "somite-physics-0",
                                 "physics": PHYSICS}]
    assert (run / "done.json").is_file()
