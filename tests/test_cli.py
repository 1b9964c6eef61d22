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
