"""``--resume`` after a random corruption of each run file (issue 23): seeded byte flips,
digits changed (a value that still parses), truncations, lines deleted, repeated, swapped or
inserted, bytes that are not UTF-8.

Each corrupted run either is refused (exit 2, one line naming the file, and the line for the
log and the bests; the directory byte for byte as it was) or, where the corruption is harmless
(a file the resume writes again), resumes to the very files of the uncorrupted run. A run that
resumes into anything else has lost or changed its history, which is what this test is for.
"""

from __future__ import annotations

import json
import random
from pathlib import Path

import pytest

from somite.cli import main

ARGS = ["evolve", "--shape", "worm", "--population", "4", "--generations", "4",
        "--checkpoint-every", "2", "--duration", "1", "--seed", "5", "--quiet"]
MORE = ["--generations", "5", "--resume"]
FILES = ("log.csv", "bests.jsonl", "checkpoint.json", "config.json", "best.json",
         "manifest.json", "physics.json")
LINED = ("log.csv", "bests.jsonl")
"""The files whose refusal names the line."""

DAMAGES = ("flip", "digit", "truncate", "delete", "repeat", "swap", "insert", "not UTF-8")
CASES = [(name, kind, seed) for name in FILES for seed, kind in enumerate(DAMAGES)]


def _files(run: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(run.iterdir()) if p.is_file()}


def _copy(files: dict[str, bytes], target: Path) -> Path:
    target.mkdir()
    for name, data in files.items():
        (target / name).write_bytes(data)
    return target


@pytest.fixture(scope="module")
def prepared(tmp_path_factory) -> tuple[dict[str, bytes], dict[str, bytes]]:
    """A finished 4-generation run's files, and those of its resume to 5 generations."""
    root = tmp_path_factory.mktemp("fuzz")
    assert main([*ARGS, "--out", str(root / "run")]) == 0
    start = _files(root / "run")
    assert set(start) == set(FILES), sorted(start)
    assert main([*ARGS, *MORE, "--out", str(root / "run")]) == 0
    return start, _files(root / "run")


def corrupt(data: bytes, kind: str, rng: random.Random) -> bytes:
    """``data`` changed by one corruption of ``kind``, its place drawn from ``rng``."""
    if kind == "digit":  # another value that still parses: only a checksum can tell
        digits = [i for i, byte in enumerate(data) if chr(byte).isdigit()]
        if digits:
            at = rng.choice(digits)
            other = rng.choice([d for d in b"0123456789" if d != data[at]])
            return data[:at] + bytes([other]) + data[at + 1:]
        kind = "flip"
    if kind == "flip":
        at = rng.randrange(len(data))
        return data[:at] + bytes([data[at] ^ (1 << rng.randrange(8))]) + data[at + 1:]
    if kind == "truncate":
        return data[: rng.randrange(len(data))]
    if kind == "not UTF-8":
        at = rng.randrange(len(data))
        return data[:at] + b"\xff\xfe\x80" + data[at:]
    lines = data.splitlines(keepends=True)
    i = rng.randrange(len(lines))
    if kind == "delete" and len(lines) > 1:
        del lines[i]
    elif kind == "repeat":
        lines.insert(i, lines[i])
    elif kind == "swap" and len(lines) > 1:
        j = rng.choice([k for k in range(len(lines)) if lines[k] != lines[i]] or [i])
        lines[i], lines[j] = lines[j], lines[i]
    else:  # "insert", and what a one-line file cannot have deleted or swapped
        garbage = "".join(rng.choice('0123456789,.-e{}[]":abc ')
                          for _ in range(rng.randint(1, 40)))
        lines.insert(i, garbage.encode() + b"\n")
    return b"".join(lines)


def _elapsed_aside(files: dict[str, bytes]) -> dict:
    """The files with the elapsed time (a resume's own, of this machine) left out."""
    out = dict(files)
    out["log.csv"] = [line.split(b",")[:2] + line.split(b",")[3:]
                      for line in files["log.csv"].splitlines()]
    state = json.loads(files["checkpoint.json"])
    out["checkpoint.json"] = {k: v for k, v in state.items()
                              if k != "elapsed_seconds"}
    return out


@pytest.mark.parametrize("name, kind, seed", CASES, ids=[f"{n}-{k}" for n, k, _ in CASES])
def test_a_corrupted_run_is_refused_or_resumes_exactly(prepared, tmp_path, capsys, name, kind,
                                                       seed):
    start, resumed = prepared
    rng = random.Random(f"{name}-{kind}-{seed}")
    files = dict(start)
    files[name] = corrupt(start[name], kind, rng)
    assert files[name] != start[name]
    run = _copy(files, tmp_path / "run")
    capsys.readouterr()
    code = main([*ARGS, *MORE, "--out", str(run)])
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    if code == 2:
        assert err.count("\n") == 1, err
        assert name in err, err  # config.json: "the checkpoint ... is not config.json's"
        if name in LINED:
            assert f"{run / name}, line " in err, err
        assert _files(run) == files  # nothing touched
        return
    assert code == 0, err
    expected = dict(resumed)
    if name == "manifest.json":
        # Not read by a resume, nor written: what --force may delete, read leniently (a
        # name it does not list is kept), so that a damaged one can only keep files.
        expected[name] = files[name]
    assert _elapsed_aside(_files(run)) == _elapsed_aside(expected), (
        f"{name} ({kind}) was resumed into another run")
