"""The command line: outcomes as JSON, one-line errors with exit code 2."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from somite.cli import main


def test_simulate_json(capsys):
    code = main(["simulate", "--shape", "worm", "--terrain", "hilly-1-10-0", "--controller",
                 "sine:freq=1,amp=1,phase=-1", "--duration", "3", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert set(report) >= {"velocity", "distance", "final_com", "max_corner_speed", "finite"}
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
