"""A cheap sample of the hostile-input probe (audits/probe.py, issue 23) re-run with new
variations: each bad or extreme input, of every class the probe tried, ends in one line and
exit 2 before any work, writes nothing (nothing outside its target in particular) and gives no
traceback."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from somite.cli import main

EMPTY_CAMPAIGN = {"format": "somite-campaign", "version": 1, "name": "x", "source": "t",
                  "experiments": {"a": {}}, "tasks": []}
TOML = ('title = "x"\n[defaults]\npopulation = 4\nduration = 1.0\n'
        '[experiments.base]\nkind = "evolve"\nshapes = ["worm"]\nseeds = 1\n')


def _snapshot(folder: Path) -> dict[str, object]:
    found = {}
    for path in sorted(folder.rglob("*")):
        key = str(path.relative_to(folder))
        if path.is_symlink():
            found[key] = ("link", os.readlink(path))
        elif path.is_file() and path.stat().st_size > 2**20:  # a sparse giant: not read
            found[key] = (path.stat().st_size, path.stat().st_mtime_ns)
        elif path.is_file():
            found[key] = path.read_bytes()
        else:
            found[key] = "folder" if path.is_dir() else "special"
    return found


def _genome_with(made_run: Path, edit) -> str:
    data = json.loads((made_run / "best.json").read_text())
    edit(data)
    return json.dumps(data)


def _string_weight(data):
    data["edges"][0]["weight"] = str(data["edges"][0]["weight"])


def _fifo(path: Path) -> None:
    os.mkfifo(path)


def _sparse(path: Path, size: int) -> None:
    with open(path, "wb") as handle:
        handle.truncate(size)


def _hard_link_outside(d: Path) -> None:
    (d / "outside.txt").write_text("mine")
    os.link(d / "outside.txt", d / "run" / ".somite.lock")


CASES = {
    # name: (setup(d, made_run), argv with {d}, words in the error)
    "a validation terrain with a trailing space": (
        None, ["evolve", "--shape", "worm", "--terrain", "hilly-1-10-10000 ", "--out", "{d}/r"],
        ["validation terrain"]),
    "a validation terrain with leading zeros": (
        None, ["evolve", "--shape", "worm", "--terrain", "hilly-1-10-0010003", "--out", "{d}/r"],
        ["write it hilly-1-10-10003"]),
    "a slope of 400 digits": (
        None, ["simulate", "--terrain", "uphill-" + "9" * 400], ["more than 30 characters"]),
    "a grid of 33 rows": (
        None, ["simulate", "--shape", "/".join(["1"] * 33)], ["at most 32 voxels"]),
    "5000-digit frames": (
        "run", ["show", "{d}/run", "--frames", "9" * 5000, "--out", "{d}/s.png"],
        ["frames="]),
    "a duration below one control step": (
        None, ["simulate", "--duration", "1e-320"], ["one control step"]),
    "a genome weight written as a string": (
        lambda d, run: (d / "g.json").write_text(_genome_with(run, _string_weight)),
        ["simulate", "--duration", "1", "--genome", "{d}/g.json"], ["edges[0].weight="]),
    "a 1 GiB genome file": (
        lambda d, run: _sparse(d / "g.json", 2**30),
        ["evaluate", "{d}/g.json", "--duration", "1"], ["larger than"]),
    "a FIFO as the figure": (
        lambda d, run: (shutil.copytree(run, d / "run"), _fifo(d / "f.png")),
        ["plot", "{d}/run", "--out", "{d}/f.png"], ["not a regular file"]),
    "a folder named like the video": (
        lambda d, run: (shutil.copytree(run, d / "run"), (d / "w.gif").mkdir()),
        ["show", "{d}/run", "--duration", "1", "--out", "{d}/w.gif"], ["is a folder"]),
    "a report folder that is a symlink to the campaign": (
        lambda d, run: ((d / "c").mkdir(), (d / "c" / "campaign.json").write_text(
            json.dumps(EMPTY_CAMPAIGN)), os.symlink(d / "c", d / "link")),
        ["report", "{d}/c", "--out", "{d}/link", "--quiet"], ["is the campaign folder"]),
    "a report folder whose index.md is a folder": (
        lambda d, run: ((d / "c").mkdir(), (d / "c" / "campaign.json").write_text(
            json.dumps(EMPTY_CAMPAIGN)), (d / "r" / "index.md").mkdir(parents=True),
            (d / "r" / "index.md" / "mine").write_text("mine")),
        ["report", "{d}/c", "--out", "{d}/r", "--quiet"], ["its index.md is a folder"]),
    "a campaign with a seed listed twice": (
        lambda d, run: (d / "x.toml").write_text(TOML.replace("seeds = 1", "seeds = [1, 1]")),
        ["campaign", "run", "{d}/x.toml", "--out", "{d}/c", "--quiet"], ["listed twice"]),
    "a campaign variant named ../x": (
        lambda d, run: (d / "x.toml").write_text(TOML + 'variants = { "../x" = {} }\n'),
        ["campaign", "run", "{d}/x.toml", "--out", "{d}/c", "--quiet"], ["variants='../x'"]),
    "a campaign task path through a symlink out of the folder": (
        lambda d, run: ((d / "outside").mkdir(), (d / "c" / "a").mkdir(parents=True),
                        os.symlink(d / "outside", d / "c" / "a" / "0"),
                        (d / "c" / "campaign.json").write_text(json.dumps({
                            **EMPTY_CAMPAIGN, "tasks": [{
                                "id": "a/0", "experiment": "a", "kind": "evolve",
                                "path": "a/0", "needs": [], "options": {
                                    "shape": "worm", "population": 4, "generations": 1,
                                    "duration": 1.0, "seed": 0}}]}))),
        ["campaign", "status", "{d}/c"], ["symbolic link"]),
    "a lock that is a FIFO": (
        lambda d, run: (shutil.copytree(run, d / "run"), _fifo(d / "run" / ".somite.lock")),
        ["evolve", "--out", "{d}/run", "--resume", "--generations", "2", "--quiet"],
        ["not a regular file"]),
    "a lock hard-linked to a file outside the run": (
        lambda d, run: (shutil.copytree(run, d / "run"), _hard_link_outside(d)),
        ["evolve", "--out", "{d}/run", "--resume", "--generations", "2", "--quiet"],
        ["hard link"]),
    "a GIF too big for memory": (
        "run", ["show", "{d}/run", "--duration", "60", "--fps", "60", "--width", "4096",
                "--height", "4096", "--out", "{d}/w.gif"], ["memory="]),
    "an evolve of a month": (
        None, ["evolve", "--shape", "worm", "--population", "5000", "--generations", "3000",
               "--duration", "60", "--out", "{d}/r"], ["give --yes"]),
}


@pytest.mark.parametrize("name", CASES)
def test_a_hostile_input_is_one_line_and_writes_nothing(name, made_run, tmp_path, capsys):
    setup, argv, words = CASES[name]
    if setup == "run":
        shutil.copytree(made_run, tmp_path / "run")
    elif setup is not None:
        setup(tmp_path, made_run)
    before = _snapshot(tmp_path)
    capsys.readouterr()
    try:
        code = main([a.replace("{d}", str(tmp_path)) for a in argv])
    except SystemExit as stop:  # argparse's refusals
        code = stop.code
    assert code == 2
    out, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if ": warning:" not in line]
    assert len(lines) == 1 and "error:" in lines[0] and "Traceback" not in err, err
    for word in words:
        assert word in lines[0], err
    assert _snapshot(tmp_path) == before


@pytest.mark.parametrize("spelling", ["4_0", "+4", " 4", "\u0664", "4.0"])
def test_an_integer_has_one_spelling(tmp_path, capsys, spelling):
    # int() reads all of these; a terrain name refuses them, so the command line does too.
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as exit:
        main(["evolve", "--shape", "worm", "--population", spelling, "--generations", "0",
              "--duration", "1", "--out", str(out)])
    assert exit.value.code == 2
    assert f"population={spelling!r}: must be an integer" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("spelling", ["1_0", "\u0661", "+1", "1 "])
def test_a_number_has_one_spelling(capsys, spelling):
    with pytest.raises(SystemExit) as exit:
        main(["simulate", "--duration", spelling])
    assert exit.value.code == 2
    assert f"duration={spelling!r}: must be a number" in capsys.readouterr().err


def test_a_campaign_title_is_bounded(tmp_path, capsys):
    spec = tmp_path / "c.toml"
    spec.write_text(TOML.replace('title = "x"', f'title = "{"t" * 100_000}"'))
    assert main(["campaign", "run", str(spec), "--out", str(tmp_path / "c")]) == 2
    assert "title=" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_sigterm_unwinds_like_ctrl_c(monkeypatch, capsys):
    import signal

    from somite.commands import simulate

    def killed(args):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not interrupt the command")

    monkeypatch.setattr(simulate, "run", killed)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["simulate", "--duration", "1"]) == 143
    assert "somite simulate: terminated" in capsys.readouterr().err
    assert signal.getsignal(signal.SIGTERM) == before
