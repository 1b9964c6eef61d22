"""The command line: outcomes as JSON, one-line errors with exit code 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from somite.cli import main


def test_simulate_json(capsys):
    code = main(["simulate", "--shape", "worm", "--terrain", "hilly-1-10-0", "--controller",
                 "sine:freq=1,amp=1,phase=-1", "--duration", "3", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report) >= {"velocity", "distance", "final_com", "max_speed", "finite"}
    assert report["finite"] is True and report["terrain"] == "hilly-1-10-0"


def test_simulate_reports_exploit_diagnostics(capsys):
    """Numbers that show an exploit without a video: orientation, tilt, time on the side,
    height of the lowest point."""
    code = main(["simulate", "--shape", "biped", "--terrain", "flat", "--controller",
                 "sine:freq=2,amp=1,phase=0", "--duration", "8", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert 0.3 <= report["min_signed_area_ratio"] < 1.0
    assert 0.0 <= report["max_tilt_deg"] <= 180.0
    assert 0.0 <= report["flipped_fraction"] <= 1.0
    assert report["max_height"] > 0.5  # pulsing in phase, the biped hops


@pytest.mark.parametrize("text, extra, says", [
    ("0.5,1.5\n", [], "in [-1, 1], not 1.5"),
    ("0.5,x\n", [], "line 1': expected numbers"),
    ("0,0\n0\n", [], "line 2': has 1 columns, the first row 2"),
    ("0,2\n", [], "in [-1, 1], not 2.0"),
    ("0,nan\n", [], "in [-1, 1], not nan"),
    ("\n", [], "has no rows"),
    ("0,0\n", ["--controller", "zero"], "controller='zero': --actions are the controller"),
])
def test_simulate_actions_refuses_a_bad_table_in_one_line(tmp_path, capsys, text, extra, says):
    path = tmp_path / "a.csv"
    path.write_text(text)
    code = main(["simulate", "--actions", str(path), "--duration", "1", *extra])
    err = capsys.readouterr().err
    assert code == 2 and says in err and err.count("\n") == 1, err


def test_simulate_actions_replays_a_table_as_the_api_does(tmp_path, capsys):
    import numpy as np

    import somite

    rows = np.random.default_rng(3).uniform(-1, 1, (7, 12))
    np.savetxt(tmp_path / "a.csv", rows, delimiter=",", fmt="%.17g")
    assert main(["simulate", "--actions", str(tmp_path / "a.csv"), "--terrain", "hilly-1-10-2",
                 "--duration", "2", "--seed", "4", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    outcome = somite.simulate(somite.Table(rows), body=somite.Body.build("worm"),
                              terrain="hilly-1-10-2", duration=2, seed=4).to_dict()
    # JSON writes a number not yet measured (2 s: all transient) as null
    outcome = {k: None if isinstance(v, float) and v != v else v for k, v in outcome.items()}
    assert {key: report[key] for key in outcome} == outcome
    assert report["controller"] == f"actions {tmp_path / 'a.csv'}"


@pytest.mark.parametrize(
    "args, field",
    [
        (["--shape", ""], "shape"),
        (["--shape", "101"], "shape"),
        (["--shape", "11/1"], "shape"),
        (["--terrain", "bumpy"], "terrain"),
        (["--controller", "sinus"], "controller"),
        (["--duration", "-1"], "duration"),
        (["--duration", "nan"], "duration"),
        (["--controller", "sine:freq=nan"], "controller.freq"),
    ],
)
def test_bad_input_is_one_line_exit_2(args, field, capsys):
    with pytest.raises(SystemExit) as stop:
        raise SystemExit(main(["simulate", *args]))
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"{field}=" in err


def test_console_script_runs_without_traceback():
    result = subprocess.run(
        [sys.executable, "-m", "somite.cli", "simulate", "--terrain", "nowhere"],
        capture_output=True, text=True,
    )
    assert result.returncode == 2
    assert result.stderr.startswith("somite simulate: error: terrain='nowhere'")


def _options(parser):
    """(command, option dest, its argparse action) for every option of every sub-command."""
    from argparse import _SubParsersAction

    for sub in (a for a in parser._actions if isinstance(a, _SubParsersAction)):
        for name, command in sub.choices.items():
            for action in command._actions:
                yield name, action.dest, action
            yield from ((f"{name} {n}", d, a) for n, d, a in _options(command))


def test_shared_options_have_one_default_everywhere():
    from somite.cli import build_parser
    from somite.commands.common import DEFAULTS

    seen = set()
    for command, dest, action in _options(build_parser()):
        if dest in DEFAULTS:
            seen.add(command.split()[0])
            # Either the one default, or None where a run's saved value comes first; the help
            # then names the same default.
            assert action.default in (DEFAULTS[dest], None), (command, dest)
            shown = f"{DEFAULTS[dest]:g}" if dest == "duration" else str(DEFAULTS[dest])
            assert shown in action.help, (command, dest, action.help)
    assert {"simulate", "evaluate", "show", "evolve", "reoptimize", "reassemble",
            "assemble", "bench"} <= seen


def test_evolve_records_the_shared_defaults(tmp_path):
    from somite.commands.common import DEFAULTS

    out = tmp_path / "run"
    assert main(["evolve", "--generations", "0", "--population", "2", "--quiet",
                 "--out", str(out)]) == 0
    saved = json.loads((out / "config.json").read_text())
    shared = {k: v for k, v in DEFAULTS.items() if k != "validation"}
    assert {k: saved[k] for k in shared} == shared


@pytest.fixture(scope="module")
def genome_file(tmp_path_factory):
    import numpy as np

    from somite.evolution.operators import initial_genome
    from somite.sim.body import Body

    path = tmp_path_factory.mktemp("genome") / "g.json"
    initial_genome(Body.build("worm"), np.random.default_rng(0)).save(path)
    return path


# Sizes past somite.limits, each refused before any work, in every command that takes one.
BEYOND = [
    ("duration", ["simulate", "--duration", "1e308"]),
    ("duration", ["simulate", "--duration", "1e-9"]),
    ("duration", ["bench", "--duration", "1e6"]),
    ("duration", ["evolve", "--out", "{out}", "--duration", "601"]),
    ("duration", ["evaluate", "{genome}", "--duration", "1e308"]),
    ("duration", ["show", "{genome}", "--out", "{out}.mp4", "--duration", "1e308"]),
    ("population", ["evolve", "--out", "{out}", "--population", "100000000"]),
    ("generations", ["evolve", "--out", "{out}", "--generations", "10000000"]),
    ("evaluations", ["evolve", "--out", "{out}", "--evaluations", "5000"]),
    ("shape", ["evolve", "--out", "{out}", "--shape", "1000x1000"]),
    ("shape", ["evolve", "--out", "{out}", "--shape", "1" * 40]),
    ("shape", ["simulate", "--shape", "100000000000x1"]),
    ("validation", ["evaluate", "{genome}", "--validation", "100000"]),
    ("fresh", ["evaluate", "{genome}", "--fresh", "100000"]),
    ("fresh", ["evaluate", "{genome}", "--fresh", "0"]),
    ("validation", ["reoptimize", "{genome}", "--out", "{out}", "--validation", "100000"]),
    ("frames", ["show", "{genome}", "--out", "{out}.png", "--frames", "100000"]),
    ("fps", ["show", "{genome}", "--out", "{out}.mp4", "--fps", "0.001"]),
]


@pytest.mark.parametrize("field, command", BEYOND)
def test_sizes_beyond_the_limits_are_one_line_and_write_nothing(field, command, tmp_path,
                                                                  genome_file, capsys):
    args = [a.format(out=tmp_path / "out", genome=genome_file) for a in command]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"error: {field}=" in err, err
    assert list(tmp_path.iterdir()) == []


# Unusable output locations, each refused before any work in every command that writes one.
OUTPUTS = [
    ("file", ["evolve", "--out", "{bad}"]),
    ("file", ["reoptimize", "{genome}", "--out", "{bad}"]),
    ("file", ["demo", "--out", "{bad}"]),
    ("file", ["discover", "{genome}", "--out", "{bad}"]),
    ("file", ["reassemble", "{genome}", "{genome}", "--out", "{bad}"]),
    ("file/sub", ["evolve", "--out", "{bad}"]),
    ("dangling", ["evolve", "--out", "{bad}"]),
    ("dangling", ["demo", "--out", "{bad}"]),
    ("dangling", ["reassemble", "{genome}", "{genome}", "--out", "{bad}"]),
    ("dangling.png", ["draw", "{genome}", "--out", "{bad}"]),
    ("dangling.json", ["module", "export", "{genome}", "--partition", "worm-halves",
                       "--module", "0", "--out", "{bad}"]),
    ("folder.png", ["draw", "{genome}", "--out", "{bad}"]),
    ("folder.png", ["plot", "{genome}", "--out", "{bad}"]),
    ("folder.mp4", ["show", "{genome}", "--out", "{bad}"]),
    ("folder.json", ["module", "export", "{genome}", "--partition", "worm-halves",
                     "--module", "0", "--out", "{bad}"]),
    ("readonly/run", ["evolve", "--out", "{bad}"]),
    ("readonly", ["discover", "{genome}", "--out", "{bad}"]),
    ("readonly/brain.png", ["draw", "{genome}", "--out", "{bad}"]),
]


@pytest.mark.parametrize("where, command", OUTPUTS)
def test_unusable_outputs_are_one_line_and_write_nothing(where, command, tmp_path, genome_file,
                                                          capsys, monkeypatch):
    (tmp_path / "file").write_text("mine\n")
    for name in ("dangling", "dangling.png", "dangling.json"):
        (tmp_path / name).symlink_to(tmp_path / "nowhere")
    for name in ("folder.png", "folder.mp4", "folder.json", "readonly"):
        (tmp_path / name).mkdir()
    if where.startswith("readonly"):
        # As root a mode of 0o555 does not stop a write; a read-only file system does.
        import somite._io

        access = os.access
        monkeypatch.setattr(somite._io.os, "access", lambda path, mode: (
            Path(path).name != "readonly" and access(path, mode)))
    before = sorted(p.name for p in tmp_path.rglob("*"))
    args = [a.format(bad=tmp_path / where, genome=genome_file) for a in command]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error: out=" in err, err
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


CORRUPT = {
    "fifo": None,
    "folder": None,
    "latin-1": "{\"é\": 1}".encode("latin-1"),
    "deep": b"[" * 200_000 + b"]" * 200_000,
    "long integer": b'{"nodes": [{"id": ' + b"9" * 5000 + b"}]}",
    "not json": b"\x00\x01",
}
READERS = {
    "genome": ["evaluate", "{file}", "--validation", "1", "--duration", "1"],
    "partition": ["draw", "{genome}", "--partition", "{file}", "--out", "{out}/b.png"],
    "config": ["evolve", "--config", "{file}", "--out", "{out}/run"],
}


@pytest.mark.parametrize("kind", CORRUPT)
@pytest.mark.parametrize("field", READERS)
def test_unreadable_input_files_are_one_line(kind, field, tmp_path, genome_file, capsys):
    path = tmp_path / "input"
    if kind == "fifo":
        os.mkfifo(path)  # reading it would wait forever
    elif kind == "folder":
        path.mkdir()
    else:
        path.write_bytes(CORRUPT[kind])
    (tmp_path / "out").mkdir()
    args = [a.format(file=path, genome=genome_file, out=tmp_path / "out")
            for a in READERS[field]]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"error: {field}=" in err, err
    assert list((tmp_path / "out").iterdir()) == []


def _genome_with(path: Path, genome_file: Path, change) -> Path:
    data = json.loads(genome_file.read_text())
    change(data)
    path.write_text(json.dumps(data))
    return path


def _weights(*values):
    def change(data):
        for edge, value in zip(data["edges"], values):
            edge["weight"] = value
    return change


@pytest.mark.parametrize("field, change, command", [
    ("edges[0].weight", _weights(1e308, -1e308), ["discover", "{g}", "--out", "{out}"]),
    ("edges[0].weight", _weights(-1e308, 1e308), ["module", "export", "{g}", "--partition",
                                                  "worm-halves", "--module", "back",
                                                  "--out", "{out}/m.json"]),
    ("edges[0].weight", _weights(1e308, 1e308), ["reassemble", "{g}", "{g}", "--out", "{out}",
                                                 "--validation", "0"]),
    ("edges[0].weight", _weights(10**400), ["evaluate", "{g}", "--duration", "1"]),
    ("body.sensors", lambda d: d["body"].update(sensors=5), ["evaluate", "{g}"]),
    ("body.sensors", lambda d: d["body"].update(sensors={"a": 1}), ["evaluate", "{g}"]),
])
def test_extreme_or_mistyped_genomes_are_one_line(field, change, command, tmp_path, genome_file,
                                                  capsys):
    genome = _genome_with(tmp_path / "g.json", genome_file, change)
    (tmp_path / "out").mkdir()
    assert main([a.format(g=genome, out=tmp_path / "out") for a in command]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"error: {field}=" in err, err
    assert list((tmp_path / "out").iterdir()) == []


def test_weights_large_but_within_the_limit_work(tmp_path, genome_file):
    genome = _genome_with(tmp_path / "g.json", genome_file, _weights(1e100, -1e100, 1e100))
    assert main(["discover", str(genome), "--out", str(tmp_path / "d")]) == 0
    assert main(["module", "export", str(genome), "--partition", "worm-halves", "--module",
                 "back", "--out", str(tmp_path / "back.json")]) == 0


def test_toml_seed_and_empty_shape_lists_are_refused(tmp_path, capsys):
    toml = tmp_path / "seed.toml"
    toml.write_text("seed = 4294967296\n")
    assert main(["evolve", "--config", str(toml), "--out", str(tmp_path / "run")]) == 2
    assert "seed=4294967296: must be in [0, 2**32)" in capsys.readouterr().err
    assert main(["bench", "--shapes", ","]) == 2
    assert "shapes=','" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["evolve", "--out", ""], "out='': is empty"),
        (["draw", "genome.json", "--out", ""], "out='': is empty"),
        (["evolve", "--modules", "x", "--out", "run"], "modules='x'"),  # omega 1: not used
        (["evolve", "--omega", "1e308", "--out", "run"], "omega=1e+308: must be at most"),
        (["simulate", "--terrain", "hilly-1-10-" + "9" * 400], "characters)"),  # cut short
        (["evolve", "--out", "/proc/somite-test"], "cannot write in /proc"),
    ],
)
def test_refused_before_anything_is_written(args, message, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and len(err) < 300, err
    assert list(tmp_path.iterdir()) == []
