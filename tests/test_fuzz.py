"""Hostile input, generated: random corruptions of every file format somite reads, random
values for the CLI's numbers and random arguments to each of the 16 commands each end in exit
0, or one line and exit 2 (never a traceback), and change nothing outside ``--out``; a refused
command writes nothing (issue 10)."""

from __future__ import annotations

import json
import os
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


def one_line_or_success(args: list[str], capsys) -> int:
    try:
        code = main(args)
    except SystemExit as stop:  # argparse refusing an argument
        code = stop.code
    err = capsys.readouterr().err
    assert code in (0, 2), (args, code, err)
    if code == 2:
        assert err.count("\n") == 1 and "Traceback" not in err, (args, err)
    return code


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
    # --generations: a config.json without the key would go on for the default 3000.
    "run/checkpoint.json": ["evolve", "--out", "{root}/run", "--resume", "--quiet",
                            "--generations", "1"],
    "run/config.json": ["evolve", "--out", "{root}/run", "--resume", "--quiet",
                        "--generations", "1"],
}


MORE = {
    # The same files read by the other commands that take them.
    "genome.json discover": ["discover", "{root}/genome.json", "--out", "{out}/found"],
    "genome.json module export": ["module", "export", "{root}/genome.json", "--partition",
                                  "worm-halves", "--module", "back", "--out", "{out}/m.json"],
    "genome.json reassemble": ["reassemble", "{root}/genome.json", "{root}/run/best.json",
                               "--partition", "worm-halves", "--out", "{out}/r",
                               "--validation", "1", "--duration", "0.5"],
    "genome.json show": ["show", "{root}/genome.json", "--duration", "0.5", "--out",
                         "{out}/s.png"],
    "genome.json reoptimize": ["reoptimize", "{root}/genome.json", "--population", "2",
                               "--generations", "0", "--duration", "0.5", "--validation", "1",
                               "--quiet", "--out", "{out}/re"],
    "library/back.json assemble": ["assemble", "{root}/library", "--place", "back@0,0",
                                   "--out", "{out}/a"],
    "found/partition.json reassemble": ["reassemble", "{root}/genome.json", "{root}/genome.json",
                                        "--partition", "{root}/found/partition.json", "--out",
                                        "{out}/r", "--validation", "0"],
}


@pytest.mark.parametrize("name", [*COMMANDS, *MORE])
def test_corrupted_files(name, files, tmp_path_factory, capsys):
    original = files / name.split(" ")[0]
    command = COMMANDS.get(name) or MORE[name]
    tmp = tmp_path_factory.mktemp("corrupt")

    @settings(FUZZ, max_examples=60 if name in COMMANDS else 30)
    @given(data=corruption(original.read_text()))
    def run(data):
        fuzz_file(files, tmp, "copy", original, data, command, capsys)

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


# -- every command, random arguments ------------------------------------------------------------
#
# Each command starts from a quick valid invocation; one of its arguments (an option, or a
# positional given as "@i") is replaced by a random value: a number, a word, or a path to
# something that is not what the command wants (a folder, a FIFO, a file that is not JSON or
# not UTF-8, a damaged genome, a path below a file, a place no one may write). Inputs must be
# left as they were.

EVERY = {
    "assemble": (["assemble", "{root}/library", "--place", "back@0,0", "--out", "{out}/a",
                  "--evaluate", "1", "--duration", "0.5"],
                 ["@1", "--place", "--out", "--evaluate", "--duration", "--seed", "--preset"]),
    "bench": (["bench", "--robots", "4", "--duration", "0.2", "--shapes", "worm",
               "--no-scaling"], ["--robots", "--duration", "--shapes"]),
    "demo": (["demo", "--generations", "-1", "--out", "{out}/demo", "--quiet"],
             ["--generations", "--out"]),
    "discover": (["discover", "{root}/run", "--out", "{out}/found"],
                 ["@1", "--out", "--min", "--max"]),
    "draw": (["draw", "{root}/genome.json", "--out", "{out}/b.svg"],
             ["@1", "--out", "--partition"]),
    "evaluate": (["evaluate", "{root}/genome.json", "--duration", "0.5", "--validation", "1"],
                 ["@1", "--validation", "--terrain", "--duration", "--seed", "--preset"]),
    "evolve": (["evolve", "--out", "{out}/run", "--population", "2", "--generations", "0",
                "--duration", "0.5", "--quiet"],
               ["--out", "--config", "--shape", "--sensors", "--terrain", "--modules",
                "--population", "--duration", "--seed", "--omega", "--evaluations", "--preset"]),
    "module export": (["module", "export", "{root}/run", "--partition", "worm-halves",
                       "--module", "back", "--out", "{out}/m.json"],
                      ["@2", "--partition", "--module", "--velocity", "--out"]),
    "module list": (["module", "list", "{root}/library"], ["@2"]),
    "plot": (["plot", "{root}/run", "--out", "{out}/p.png"],
             ["@1", "--out", "--group-by", "--kind"]),
    "reassemble": (["reassemble", "{root}/run", "{root}/genome.json", "--partition",
                    "worm-halves", "--out", "{out}/r", "--validation", "1", "--duration", "0.5"],
                   ["@1", "@2", "--partition", "--out", "--receiver-shape", "--take",
                    "--receiver-partition", "--validation", "--duration"]),
    "report": (["report", "{pool}/folder", "--out", "{out}/report", "--quiet"],
               ["@1", "--out", "--validation"]),
    "reoptimize": (["reoptimize", "{root}/genome.json", "--donors", "{root}/run",
                    "--population", "2", "--generations", "0", "--duration", "0.5",
                    "--validation", "1", "--quiet", "--out", "{out}/re"],
                   ["@1", "--donors", "--out", "--population", "--validation", "--config",
                    "--duration"]),
    "show": (["show", "{root}/genome.json", "--duration", "0.5", "--out", "{out}/s.png"],
             ["@1", "--out", "--terrain", "--frames", "--fps", "--width", "--height"]),
    "simulate": (["simulate", "--duration", "0.5", "--json"],
                 ["--shape", "--sensors", "--terrain", "--controller", "--duration", "--seed",
                  "--preset"]),
}

VALUES = st.sampled_from([
    # numbers
    "nan", "-inf", "-1", "0", "1", "1e308", "1e-9", "99999999999999999999", "0.001", "1e-300",
    # words
    "", "x", ",", "worm", "1111/1111", "1x1", "back@0,0", "back@-5,99999", "@", "a=b:c",
    "hilly-1-10-3", "paper", "\udcff",
    # paths
    "{pool}/missing", "{pool}/folder", "{pool}/fifo", "{pool}/text.json", "{pool}/latin1.toml",
    "{pool}/deep.json", "{pool}/huge-weight.json", "{pool}/text.json/below", "/proc/somite",
    "{root}/run", "{root}/genome.json", "{root}/library/back.json", "{root}/found/partition.json",
])

SLOW = {("demo", "--generations"): {"0", "1"}}
"""Valid values that would start a long run (the demo's 48 robots, 20 s episodes and video):
not tried."""
REFUSED_ONLY = {"demo", "report"}
"""Commands fuzzed from a refused start (the demo is long, a campaign costs minutes to build):
every value must be refused."""


def make_pool(pool: Path, genome: Path) -> None:
    """Files that are not what a command wants, made again for each example."""
    shutil.rmtree(pool, ignore_errors=True)
    (pool / "folder").mkdir(parents=True)
    os.mkfifo(pool / "fifo")
    (pool / "text.json").write_text("not json at all\n")
    (pool / "latin1.toml").write_bytes(b"seed = 1 # caf\xe9\n")
    (pool / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    data = json.loads(genome.read_text())
    data["edges"][0]["weight"] = 1e308
    (pool / "huge-weight.json").write_text(json.dumps(data))


def with_value(base: list[str], name: str, value: str) -> list[str]:
    if name.startswith("@"):
        at = int(name[1:])
        return [*base[:at], value, *base[at + 1:]]
    return [*base, f"{name}={value}"]


@pytest.mark.parametrize("command", EVERY)
def test_random_arguments_to_every_command(command, files, tmp_path_factory, capsys,
                                           monkeypatch):
    base, names = EVERY[command]
    tmp = tmp_path_factory.mktemp("every")
    root, out, pool, cwd = tmp / "root", tmp / "out", tmp / "pool", tmp / "cwd"

    def fresh(*args: str) -> list[str]:
        # The inputs too: an --out among them may be written (module export --out genome.json).
        for folder in (root, out):
            shutil.rmtree(folder, ignore_errors=True)
        shutil.copytree(files, root)
        out.mkdir()
        for path in cwd.iterdir():
            shutil.rmtree(path) if path.is_dir() else path.unlink()
        make_pool(pool, files / "genome.json")
        return [a.format(root=root, out=out, pool=pool) for a in args]

    cwd.mkdir()
    monkeypatch.chdir(cwd)  # a relative --out lands here
    if command not in REFUSED_ONLY:
        assert main(fresh(*base)) == 0, "the starting point must be a valid command"
        capsys.readouterr()

    @settings(FUZZ, max_examples=80)
    @given(name=st.sampled_from(names), value=VALUES)
    def run(name, value):
        if value in SLOW.get((command, name), ()):
            return
        args = fresh(*with_value(base, name, value))
        # Asked to write among the inputs (--out {root}/run), a command may change that.
        mine = Path(value.format(root=root, out=out, pool=pool)) if name == "--out" else out
        before = snapshot(root, mine)
        code = one_line_or_success(args, capsys)
        assert snapshot(root, mine) == before
        if code == 2:  # refused: nothing written
            assert [*out.iterdir(), *cwd.iterdir()] == [], args
        if command in REFUSED_ONLY:
            assert code == 2, args

    run()
