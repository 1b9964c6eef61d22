"""NaN or infinity in a controller or in the physics is counted (``non_finite``) and shown to
the user, never clamped in silence (issue 10)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

import somite.tasks.task
import somite.tasks.validation
from somite.brain.compile import compile_genome
from somite.brain.controllers import GraphArrays, Sine
from somite.cli import main
from somite.evolution.operators import initial_genome
from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.sim.config import SimConfig
from somite.sim.system import compile_system
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import compile_controllers, outcomes, run
from somite.tasks.task import simulate


def exploding(genome) -> GraphArrays:
    """The genome's controller with weights +inf and -inf: inf * 0 and inf - inf are NaN."""
    arrays = compile_genome(genome)
    weight = np.where(np.arange(arrays.n_edges) % 2 == 0, np.inf, -np.inf)
    return GraphArrays(arrays.node_kind, arrays.node_ref, arrays.src, arrays.dst, weight,
                       arrays.bias)


@pytest.fixture(scope="module")
def genome(worm):
    return initial_genome(worm, np.random.default_rng(0))


def test_a_normal_robot_counts_no_non_finite_step(genome):
    outcome = simulate(genome, "hilly-1-10-0", duration=3.0)
    assert outcome.finite and outcome.non_finite == 0


def test_nan_actuation_is_counted_at_every_step_it_happens(genome):
    outcome = simulate(exploding(genome), "hilly-1-10-0", body=genome.body, duration=3.0)
    assert outcome.non_finite > 0
    # The physics clamps the actuation and goes on: the episode itself stays finite.
    assert outcome.finite and outcome.to_dict()["non_finite"] == outcome.non_finite
    assert outcome.non_finite <= 3 * 60


def test_a_non_finite_physics_state_is_counted_and_stops_the_episode(worm):
    config = SimConfig(duration=1.0)
    system = compile_system([worm, worm], [parse_terrain("flat")] * 2, config.start_gap)
    system.initial_pos[1, 0, 0] = np.nan
    trace = run(system, compile_controllers([Sine(), Sine()], [worm.shape.n_voxels] * 2),
                config, [0, 0])
    good, broken = outcomes(trace, config)
    assert good.finite and good.non_finite == 0
    assert not broken.finite and broken.non_finite == 1 and np.isnan(broken.velocity)


def test_simulate_command_reports_and_warns(capsys):
    assert main(["simulate", "--controller", "sine:freq=1e308", "--duration", "1",
                 "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["non_finite"] == 60
    # One warning for the non-finite steps, one for the 1 s episode (within the transient).
    assert captured.err.count("\n") == 2 and "at 60 control steps" in captured.err
    assert "measured over the whole episode" in captured.err
    assert main(["simulate", "--controller", "sine", "--duration", "6", "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["non_finite"] == 0 and captured.err == ""


@pytest.mark.parametrize("as_json", [True, False])
def test_evaluate_command_reports_and_warns(as_json, genome, tmp_path, monkeypatch, capsys):
    genome.save(tmp_path / "g.json")
    args = ["evaluate", str(tmp_path / "g.json"), "--terrain", "flat", "--terrain",
            "hilly-1-10-0", "--duration", "2"]
    assert main([*args, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["non_finite"] == 0
    monkeypatch.setattr(somite.tasks.validation, "compile_genome", exploding)
    assert main(args + (["--json"] if as_json else [])) == 0
    captured = capsys.readouterr()
    assert "warning" in captured.err and "2 of 2 terrains" in captured.err
    if as_json:
        report = json.loads(captured.out)
        assert report["non_finite"] == 2
        assert all(n > 0 for n in report["non_finite_steps"].values())
    else:
        assert captured.out.count("non-finite at") == 2


def test_evolution_log_counts_non_finite_episodes(tmp_path, monkeypatch):
    config = resolve({"shape": "worm", "population": 4, "generations": 2, "duration": 1.0,
                      "seed": 1})
    evolve(config, tmp_path / "normal")
    monkeypatch.setattr(somite.tasks.task, "compile_genome", exploding)
    evolve(config, tmp_path / "exploding")
    for name, expected in (("normal", lambda n: n == 0), ("exploding", lambda n: n > 0)):
        with open(tmp_path / name / "log.csv") as handle:
            counts = [int(row["non_finite_episodes"]) for row in csv.DictReader(handle)]
        assert len(counts) == 3 and all(map(expected, counts)), (name, counts)
