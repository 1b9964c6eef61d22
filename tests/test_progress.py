"""Progress shows off a terminal too (a log, ``| tee``): the compile note at once, then a plain
line now and then saying where the wait is; ``--quiet`` silences it, results stay on stdout."""

from __future__ import annotations

import json

import pytest

from somite.cli import main
from somite.commands import _progress, evolve

EVOLVE = ["evolve", "--shape", "worm", "--terrain", "flat", "--population", "4",
          "--generations", "2", "--duration", "1", "--validate-every", "0"]


@pytest.fixture
def often(monkeypatch):
    """A heartbeat every millisecond, so that any wait shows one."""
    monkeypatch.setattr(_progress, "HEARTBEAT_SECONDS", 0.001)


@pytest.fixture
def cold(monkeypatch):
    """As on a fresh clone: the kernels are not compiled yet."""
    monkeypatch.setattr(_progress, "will_compile", lambda backend="cpu": True)
    monkeypatch.setattr(evolve, "will_compile", lambda backend="cpu": True)


def test_an_evolution_off_a_terminal_says_where_it_is(often, cold, tmp_path, capsys):
    assert main([*EVOLVE, "--out", str(tmp_path / "run")]) == 0
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert lines[0] == _progress.COMPILING + "..."
    beats = [line for line in lines if "/2 generations: " in line]
    assert beats and all(line.endswith(" s elapsed)") for line in beats), err
    assert beats[0].startswith("0/2 generations: compiling the kernels first"), beats
    # Results on stdout, progress never there.
    assert out.startswith("best v_x ") and "elapsed" not in out


def test_quiet_is_quiet(often, cold, tmp_path, capsys):
    assert main([*EVOLVE, "--out", str(tmp_path / "run"), "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert out == "" and "elapsed" not in err and "compiling" not in err


def test_a_simulation_says_it_compiles_and_keeps_its_json_clean(often, cold, capsys):
    assert main(["simulate", "--duration", "6", "--json"]) == 0
    out, err = capsys.readouterr()
    assert err.splitlines()[0] == _progress.COMPILING + "..."
    assert all(line.startswith("simulating 6 s (compiling the kernels first) (")
               for line in err.splitlines()[1:]), err
    report = json.loads(out)  # stdout is the JSON alone
    assert report["units"]["velocity"] == "m/s" and report["units"]["min_height"] == "m"


def test_a_warm_cache_says_nothing_of_compiling(often, monkeypatch, capsys):
    monkeypatch.setattr(_progress, "will_compile", lambda backend="cpu": False)
    assert main(["simulate", "--duration", "6"]) == 0
    assert "compiling" not in capsys.readouterr().err


def test_a_heartbeat_line_names_the_count_and_the_seconds():
    wait = _progress.Waiting("best v_x 0.120 m/s, |G| 40", total=60, unit="generations")
    wait.update(done=3)
    assert wait.line().startswith("3/60 generations: best v_x 0.120 m/s, |G| 40 (")
    assert _progress.Waiting("drawing the figures").line().startswith("drawing the figures (")


def test_simulate_prints_every_number_with_its_unit(capsys):
    assert main(["simulate", "--shape", "worm", "--duration", "6"]) == 0
    rows = [line.split(": ", 1) for line in capsys.readouterr().out.splitlines()]
    shown = {key.strip(): value.split("  ")[0] for key, value in rows}  # the value, its unit
    for key, unit in (("duration", "s"), ("velocity", "m/s"), ("distance", "m"),
                      ("final_com", "m"), ("max_speed", "m/s"), ("max_tilt_deg", "deg"),
                      ("max_height", "m"), ("min_height", "m"), ("non_finite", "control steps")):
        assert shown[key].endswith(f" {unit}"), (key, shown[key])
        for number in shown[key].removesuffix(f" {unit}").split(", "):
            float(number)
