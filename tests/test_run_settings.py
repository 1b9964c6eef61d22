"""A run directory remembers its settings: every command given a run's genome simulates with
the run's duration, preset and (fixed) training terrain unless told otherwise, and says so."""

from __future__ import annotations

import csv
import json

import pytest

from somite.cli import main
from somite.experiments.config import resolve
from somite.experiments.origin import origin_of
from somite.experiments.runner import evolve

RUN = {"shape": "worm", "population": 4, "generations": 1, "duration": 2.0, "transient": 1.0,
       "preset": "original-code", "terrain": "flat", "seed": 5, "validate_every": 1}
"""Everything a command could take from the run differs from the commands' own defaults."""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("settings") / "run"
    evolve(resolve(RUN), path)
    return path


def test_the_origin_of_a_run_and_of_its_files(run, tmp_path):
    for target in (run, run / "best.json"):
        origin = origin_of(target)
        assert (origin.duration, origin.transient, origin.preset) == (2.0, 1.0, "original-code")
        assert origin.fixed_terrain() == "flat"
        with open(run / "log.csv") as handle:
            last = list(csv.DictReader(handle))[-1]["validation_velocity"]
        assert origin.validation_velocity == pytest.approx(float(last))
    loose = tmp_path / "loose.json"
    loose.write_text((run / "best.json").read_text())
    assert origin_of(loose).options() == {}
    assert origin_of(loose).source == ""


def test_evaluate_uses_the_runs_settings_unless_given(run, capsys):
    assert main(["evaluate", str(run), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert list(report["terrains"]) == ["flat"]
    settings = report["settings"]
    assert (settings["duration"], settings["transient"], settings["preset"]) == \
        (2.0, 1.0, "original-code")
    assert settings["from"] == f"run {run}"
    assert main(["evaluate", str(run), "--duration", "3", "--preset", "paper",
                 "--validation", "2", "--terrain", "uphill-5", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert list(report["terrains"]) == ["uphill-5"]
    assert (report["settings"]["duration"], report["settings"]["preset"]) == (3.0, "paper")
    assert main(["evaluate", str(run)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("settings: the run's terrain flat, 2 s (v_x over [1 s, 2 s]), "
                          f"preset original-code, seed 0; from run {run} where not given")


def test_a_run_on_random_terrains_is_evaluated_on_the_validation_terrains(tmp_path, capsys):
    evolve(resolve({**RUN, "terrain": "hilly-1-10-rnd", "validate_every": 0}), tmp_path / "r")
    assert main(["evaluate", str(tmp_path / "r"), "--validation", "2", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert list(report["terrains"]) == ["hilly-1-10-10000", "hilly-1-10-10001"]
    assert report["settings"]["duration"] == 2.0
    # The diagnostics at the top are the worst terrain's, and the file says so (past the
    # first 2 s, which they leave out).
    assert main(["evaluate", str(tmp_path / "r"), "--validation", "2", "--duration", "4",
                 "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    per_terrain = report["diagnostics"].values()
    assert all(d["max_tilt_deg"] is not None for d in per_terrain)
    assert report["flipped_fraction"] == max(d["flipped_fraction"] for d in per_terrain)
    assert report["min_height"] == min(d["min_height"] for d in per_terrain)
    assert report["over_terrains"]["flipped_fraction"] == "most over the terrains"
    assert report["over_terrains"]["min_height"] == "least over the terrains"


def test_show_and_simulate_use_the_runs_settings(run, tmp_path, capsys):
    strip = tmp_path / "strip.png"
    assert main(["show", str(run / "best.json"), "--out", str(strip), "--frames", "2"]) == 0
    out = capsys.readouterr().out
    assert "settings: flat, 2 s" in out and "preset original-code" in out
    assert "on flat, 2 s" in out
    assert main(["simulate", "--genome", str(run), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["duration"] == 2.0 and report["shape"] == "111111/111111"
    assert main(["simulate", "--genome", str(run), "--shape", "biped"]) == 2
    assert "shape='biped'" in capsys.readouterr().err


def test_reassemble_then_reoptimize_keep_the_donors_settings(run, tmp_path, capsys):
    out = tmp_path / "re"
    assert main(["reassemble", str(run), str(run / "best.json"), "--out", str(out),
                 "--validation", "2"]) == 0
    printed = capsys.readouterr()
    assert "settings: 2 validation terrains, 2 s" in printed.out
    validation = json.loads((out / "report.json").read_text())["validation"]
    assert (validation["duration"], validation["transient"], validation["preset"]) == \
        (2.0, 1.0, "original-code")
    # The donors hardly move in 2 s of a 1-generation run: rho says so.
    assert "rho divides by it" in printed.err
    donors = json.loads((out / "report.json").read_text())["donors"]
    assert [d["terrain"] for d in donors] == ["flat", "flat"]
    again = tmp_path / "again"
    assert main(["reoptimize", str(out / "reassembled.json"), "--donors", str(run),
                 "--generations", "1", "--population", "4", "--validation", "2",
                 "--out", str(again)]) == 0
    config = json.loads((again / "config.json").read_text())
    assert (config["duration"], config["transient"], config["preset"]) == \
        (2.0, 1.0, "original-code")
    # Donors trained on flat: their reassembly is re-optimised on flat, and says so.
    assert config["terrain"] == "flat"
    assert f"settings: training on flat (from reassembly {out}), 2 s" in \
        capsys.readouterr().out
    # A genome with no run of its own takes the terrain its donors' runs shared.
    loose = tmp_path / "loose.json"
    loose.write_text((out / "reassembled.json").read_text())
    for donors, terrain, said in (([str(run), str(run / "best.json")], "flat",
                                   f"(from run {run}, run {run})"),
                                  ([], "hilly-1-10-rnd", "(the default: no run to inherit")):
        target = tmp_path / f"loose-{len(donors)}"
        assert main(["reoptimize", str(loose), *(["--donors", *donors] if donors else []),
                     "--generations", "1", "--population", "4", "--validation", "1",
                     "--duration", "1", "--out", str(target)]) == 0
        assert json.loads((target / "config.json").read_text())["terrain"] == terrain
        assert f"settings: training on {terrain} {said}" in capsys.readouterr().out
    from_run = tmp_path / "from-run"
    assert main(["reoptimize", str(run), "--generations", "1", "--population", "4",
                 "--validation", "1", "--duration", "1.5", "--out", str(from_run),
                 "--quiet"]) == 0
    config = json.loads((from_run / "config.json").read_text())
    assert (config["duration"], config["preset"], config["terrain"]) == \
        (1.5, "original-code", "flat")


def test_module_export_records_the_runs_validation_velocity(run, tmp_path, capsys):
    out = tmp_path / "front.json"
    assert main(["module", "export", str(run), "--partition", "worm-halves",
                 "--module", "front", "--out", str(out)]) == 0
    assert f"from run {run}" in capsys.readouterr().out
    recorded = json.loads(out.read_text())["provenance"]["donor_velocity"]
    assert recorded == pytest.approx(origin_of(run).validation_velocity)


def test_assemble_evaluates_with_its_modules_donors_settings(run, tmp_path, capsys):
    lib = tmp_path / "lib"
    for module in ("back", "front"):
        assert main(["module", "export", str(run), "--partition", "worm-halves", "--module",
                     module, "--out", str(lib / f"{module}.json")]) == 0
    out = tmp_path / "robot"
    assert main(["assemble", str(lib), "--place", "back@0,0", "--place", "front@3,0",
                 "--evaluate", "1", "--out", str(out)]) == 0
    evaluation = json.loads((out / "evaluation.json").read_text())
    assert (evaluation["duration"], evaluation["preset"]) == (2.0, "original-code")
    assert f"from run {run}, run {run} where not given" in capsys.readouterr().out
    assert main(["assemble", str(lib), "--place", "back@0,0", "--place", "front@3,0",
                 "--evaluate", "1", "--duration", "1.5", "--preset", "paper",
                 "--out", str(tmp_path / "given")]) == 0
    evaluation = json.loads((tmp_path / "given" / "evaluation.json").read_text())
    assert (evaluation["duration"], evaluation["preset"]) == (1.5, "paper")
