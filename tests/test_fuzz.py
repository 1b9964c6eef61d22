"""Hostile input, generated: random corruptions of every file format somite reads and random
values for the CLI's numbers each end in exit 0, or one line and exit 2 (never a traceback),
and change nothing outside ``--out`` (issue 10)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from somite.cli import main
from somite.evolution.operators import initial_genome
from somite.sim.body import Body

FUZZ = settings(max_examples=60, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture])

WEIRD = st.sampled_from([
    None, True, -5, 0, 1, 2**32, 10**400, 1e308, -1e308, 0.5, "", "x", "nan", [], {}, [[]],
    {"a": 1}, [1, 2, 3], "1111/1111", -0.0,
])


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """A small finished run, its genome, the worm-halves partition and a module library."""
    root = tmp_path_factory.mktemp("fuzz")
    run = root / "run"
    assert main(["evolve", "--shape", "worm", "--population", "4", "--generations", "1",
                 "--duration", "1", "--seed", "1", "--quiet", "--out", str(run)]) == 0
    initial_genome(Body.build("worm"), np.random.default_rng(0)).save(root / "genome.json")
    assert main(["discover", str(run), "--out", str(root / "found")]) == 0
    (root / "library").mkdir()
    assert main(["module", "export", str(run), "--partition", "worm-halves", "--module",
                 "back", "--out", str(root / "library" / "back.json")]) == 0
    return root


def paths(data, prefix=()):
    """Every place in a JSON document, as a key path."""
    yield prefix
    if isinstance(data, dict):
        for key, value in data.items():
            yield from paths(value, (*prefix, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from paths(value, (*prefix, i))


def replaced(data, path, value):
    if not path:
        return value
    head, rest = path[0], path[1:]
    copy = dict(data) if isinstance(data, dict) else list(data)
    copy[head] = replaced(data[head], rest, value)
    return copy


@st.composite
def corruption(draw, text: str) -> bytes:
    """A JSON file with one value replaced by a strange one, a key dropped, or its bytes cut
    or flipped."""
    kind = draw(st.sampled_from(["value", "value", "drop", "cut", "flip"]))
    raw = text.encode()
    if kind == "cut":
        return raw[: draw(st.integers(0, len(raw) - 1))]
    if kind == "flip":
        at = draw(st.integers(0, len(raw) - 1))
        return raw[:at] + bytes([draw(st.integers(0, 255))]) + raw[at + 1:]
    data = json.loads(text)
    places = list(paths(data))
    place = places[draw(st.integers(0, len(places) - 1))]
    if kind == "drop" and place and isinstance(place[-1], str):
        parent = place[:-1]
        inner = data
        for key in parent:
            inner = inner[key]
        trimmed = {k: v for k, v in inner.items() if k != place[-1]}
        return json.dumps(replaced(data, parent, trimmed)).encode()
    return json.dumps(replaced(data, place, draw(WEIRD))).encode()


def snapshot(root: Path, out: Path) -> dict:
    return {p: p.read_bytes() for p in root.rglob("*")
            if p.is_file() and out not in p.parents and p != out}


def one_line_or_success(args: list[str], capsys) -> None:
    try:
        code = main(args)
    except SystemExit as stop:  # argparse refusing an argument
        code = stop.code
    err = capsys.readouterr().err
    assert code in (0, 2), (args, code, err)
    if code == 2:
        assert err.count("\n") == 1 and "Traceback" not in err, (args, err)


def fuzz_file(files: Path, tmp_path: Path, name: str, original: Path, data: bytes, command,
              capsys) -> None:
    work = tmp_path / name
    shutil.rmtree(work, ignore_errors=True)
    shutil.copytree(files, work)
    target = work / original.relative_to(files)
    target.write_bytes(data)
    out = work / "out"
    out.mkdir()
    before = snapshot(work, out)
    one_line_or_success([a.format(root=work, out=out) for a in command], capsys)
    if "--resume" not in command:  # a resume writes its run directory, which is its --out
        assert snapshot(work, out) == before


COMMANDS = {
    "genome.json": ["evaluate", "{root}/genome.json", "--validation", "1", "--duration", "0.5"],
    "found/partition.json": ["draw", "{root}/genome.json", "--partition",
                             "{root}/found/partition.json", "--out", "{out}/b.svg"],
    "library/back.json": ["module", "list", "{root}/library"],
    "run/checkpoint.json": ["evolve", "--out", "{root}/run", "--resume", "--quiet"],
    "run/config.json": ["evolve", "--out", "{root}/run", "--resume", "--quiet"],
}


@pytest.mark.parametrize("name", COMMANDS)
def test_corrupted_files(name, files, tmp_path_factory, capsys):
    original = files / name
    tmp = tmp_path_factory.mktemp("corrupt")

    @FUZZ
    @given(data=corruption(original.read_text()))
    def run(data):
        fuzz_file(files, tmp, "copy", original, data, COMMANDS[name], capsys)

    run()


NUMBERS = st.sampled_from(["nan", "inf", "-inf", "-1", "0", "1", "1e308", "1e-9", "1e6",
                           "99999999999999999999", "abc", "", "0.001", "3", "1e-300"])
OPTIONS = {
    "simulate": (["simulate", "--duration", "0.5"],
                 ["--duration", "--seed", "--shape"]),
    "evolve": (["evolve", "--out", "{out}", "--population", "2", "--generations", "0",
                "--duration", "0.5", "--quiet"],
               ["--duration", "--population", "--generations", "--seed", "--omega",
                "--evaluations", "--checkpoint-every", "--validate-every", "--shape"]),
    "show": (["show", "{root}/genome.json", "--duration", "0.5", "--out", "{out}/s.png"],
             ["--frames", "--fps", "--width", "--height", "--duration"]),
    "evaluate": (["evaluate", "{root}/genome.json", "--duration", "0.5", "--validation", "1"],
                 ["--validation", "--duration", "--seed"]),
}


@pytest.mark.parametrize("command", OPTIONS)
def test_random_numbers_on_the_command_line(command, files, tmp_path_factory, capsys):
    base, names = OPTIONS[command]
    tmp = tmp_path_factory.mktemp("numbers")

    @FUZZ
    @given(option=st.sampled_from(names), value=NUMBERS)
    def run(option, value):
        out = tmp / "out"
        shutil.rmtree(out, ignore_errors=True)
        if command == "show":
            out.mkdir()
        before = snapshot(files, out)
        args = [a.format(root=files, out=out) for a in base]
        if option == "--duration" and value in ("1e6", "1e308", "3"):
            return  # too long or valid but long episodes: tested elsewhere
        one_line_or_success([*args, f"{option}={value}"], capsys)
        assert snapshot(files, out) == before

    run()
