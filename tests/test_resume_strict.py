"""``--resume`` is all or nothing: a damaged or inconsistent history is refused in one line
with every file as it was; only a torn last line (a kill mid-append) is the run's own."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from somite.cli import main

ARGS = ["evolve", "--shape", "worm", "--population", "4", "--generations", "6",
        "--checkpoint-every", "2", "--duration", "1", "--seed", "2", "--quiet"]


def _args(run: Path, *extra: str) -> list[str]:
    return [*ARGS, "--out", str(run), *extra]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished 6-generation run (checkpointed at its end), which ``--generations 8
    --resume`` would continue."""
    root = tmp_path_factory.mktemp("resume")
    assert main(_args(root / "whole")) == 0
    return root / "whole"


def _files(run: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(run.iterdir()) if p.is_file()}


def _copy(source: Path, target: Path) -> Path:
    target.mkdir()
    for name, data in _files(source).items():
        (target / name).write_bytes(data)
    return target


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines(keepends=True)


def _edit_log(run: Path, edit) -> None:
    lines = _lines(run / "log.csv")
    (run / "log.csv").write_text("".join(edit(lines)))


def _checkpoint(run: Path, edit) -> None:
    data = json.loads((run / "checkpoint.json").read_text())
    edit(data)
    (run / "checkpoint.json").write_text(json.dumps(data))


def _cell(line: str, index: int, value: str) -> str:
    cells = line.rstrip("\n").split(",")
    cells[index] = value
    return ",".join(cells) + "\n"


def _swap(lines, i, j):
    lines[i], lines[j] = lines[j], lines[i]
    return lines


CORRUPTIONS = {
    "generation as a float": lambda r: _edit_log(
        r, lambda ls: [ls[0], *ls[1:4], ls[4].replace("3,", "3.0,", 1), *ls[5:]]),
    "an extra header column": lambda r: _edit_log(r, lambda ls: [ls[0][:-1] + ",x\n", *ls[1:]]),
    "a row deleted": lambda r: _edit_log(r, lambda ls: ls[:3] + ls[4:]),
    "a row repeated": lambda r: _edit_log(r, lambda ls: ls[:3] + [ls[2]] + ls[3:]),
    "rows swapped": lambda r: _edit_log(r, lambda ls: _swap(ls, 2, 3)),
    "generation -1": lambda r: _edit_log(r, lambda ls: [ls[0], "-1" + ls[1][1:], *ls[2:]]),
    "a text cell": lambda r: _edit_log(r, lambda ls: [*ls[:3], _cell(ls[3], 3, "fast"),
                                                       *ls[4:]]),
    "not UTF-8": lambda r: (r / "log.csv").write_bytes((r / "log.csv").read_bytes()
                                                       + b"\xff\xfe,\n"),
    "a [] line in bests": lambda r: (r / "bests.jsonl").write_text(
        "".join(_lines(r / "bests.jsonl")[:2] + ["[]\n"] + _lines(r / "bests.jsonl")[3:])),
    "a deep line in bests": lambda r: (r / "bests.jsonl").write_text(
        "".join(_lines(r / "bests.jsonl")[:2] + ["[" * 100_000 + "]" * 100_000 + "\n"]
                + _lines(r / "bests.jsonl")[3:])),
    "a FIFO for bests": lambda r: ((r / "bests.jsonl").unlink(), os.mkfifo(r / "bests.jsonl")),
    "checkpoint generation moved": lambda r: _checkpoint(r, lambda d: d.update(generation=4)),
    "checkpoint population 3": lambda r: _checkpoint(r, lambda d: [d[k].pop() for k in (
        "population", "fitness", "origins")]),
    "checkpoint evaluations -5": lambda r: _checkpoint(r, lambda d: d.update(evaluations=-5)),
    "checkpoint all-NaN fitness": lambda r: _checkpoint(
        r, lambda d: d.update(fitness=[None] * len(d["fitness"]))),
    # Values that still parse: only the checkpoint's seal tells.
    "a median velocity changed": lambda r: _edit_log(
        r, lambda ls: [*ls[:3], _cell(ls[3], 4, "0.5"), *ls[4:]]),
    "a checkpoint weight changed": lambda r: _checkpoint(
        r, lambda d: d["population"][0]["edges"][0].__setitem__(2, 0.125)),
    "a best's velocity changed": lambda r: (r / "bests.jsonl").write_text("".join(
        line.replace('"velocity":', '"velocity":1', 1) if n == 2 else line
        for n, line in enumerate(_lines(r / "bests.jsonl")))),
}


@pytest.mark.parametrize("name", CORRUPTIONS)
def test_a_damaged_history_is_refused_and_left_alone(finished, tmp_path, capsys, name):
    run = _copy(finished, tmp_path / "run")
    CORRUPTIONS[name](run)
    before = {p.name: (p.read_bytes() if p.is_file() else None) for p in run.iterdir()}
    capsys.readouterr()
    assert main(_args(run, "--generations", "8", "--resume")) == 2, name
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    after = {p.name: (p.read_bytes() if p.is_file() else None) for p in run.iterdir()}
    assert after == before


def test_a_torn_last_line_is_the_runs_own(finished, tmp_path, capsys):
    """Killed mid-append after its checkpoint: the resumed run ends as the whole one."""
    short = tmp_path / "short"
    assert main(_args(short, "--generations", "4")) == 0
    for name, whole in (("log.csv", finished / "log.csv"),
                        ("bests.jsonl", finished / "bests.jsonl")):
        lines, own = _lines(whole), _lines(short / name)
        kept = len(lines) - 2  # generation 5 complete is gone; half of generation 5 is there
        assert len(own) == kept  # the short run's own lines, up to its checkpoint
        (short / name).write_text("".join(own) + lines[kept][: len(lines[kept]) // 2])
    capsys.readouterr()
    assert main(_args(short, "--generations", "6", "--resume")) == 0
    for name in ("bests.jsonl", "best.json"):  # the checkpoint holds the elapsed time
        assert (short / name).read_bytes() == (finished / name).read_bytes(), name
    # Elapsed time aside, and the validation velocity, which the short run measured at its
    # end (generation 4) and the whole run did not.
    strip = [line.split(",")[:2] + line.split(",")[3:-1] for line in _lines(short / "log.csv")]
    assert strip == [line.split(",")[:2] + line.split(",")[3:-1]
                     for line in _lines(finished / "log.csv")]


def test_a_bare_resume_of_a_run_killed_before_its_config_is_refused(tmp_path, capsys):
    (tmp_path / "run").mkdir()
    assert main(["evolve", "--out", str(tmp_path / "run"), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "killed before it saved config.json" in err and err.count("\n") == 1
    assert list((tmp_path / "run").iterdir()) == []


def test_a_checkpoint_sealed_as_the_run_writes_is_the_one_sealed_from_its_files(
        finished, tmp_path, monkeypatch):
    """The digests a run keeps as it writes its history seal every checkpoint exactly as
    reading log.csv and bests.jsonl again does (as runs sealed before they were kept): a
    new run, a resume's cut-back, and a cut-back over a thinned best (a pack's)."""
    from somite.experiments import runner
    from somite.experiments.history import line_digest, seal_checkpoint, thinned_line

    sealed = []

    def both_ways(data, folder, digests=None):
        assert digests is not None
        kept = seal_checkpoint(data, folder, digests)
        assert kept == seal_checkpoint(data, folder), data["generation"]
        sealed.append(data["generation"])
        return kept

    monkeypatch.setattr(runner, "seal_checkpoint", both_ways)
    assert main(_args(tmp_path / "new", "--generations", "3")) == 0
    run = _copy(finished, tmp_path / "thinned")
    lines = _lines(run / "bests.jsonl")
    lines[3] = thinned_line(3, line_digest("bests", lines[3].rstrip("\n"))) + "\n"
    (run / "bests.jsonl").write_text("".join(lines))
    assert main(_args(run, "--generations", "8", "--resume")) == 0
    assert sealed == [0, 2, 3, 8]
    assert _lines(run / "bests.jsonl")[3] == lines[3]
