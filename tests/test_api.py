"""The public API (issue 9): ask/tell, the task, terrain distributions, one NaN rule."""

from __future__ import annotations

import csv
import json
import math
import runpy
from pathlib import Path

import numpy as np
import pytest

import somite
from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.experiments import reoptimize as reoptimize_module
from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.modules.transfer import Transferability
from somite.tasks.distributions import parse_distribution
from somite.tasks.velocity import mean_velocity, rho

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["--shape", "worm", "--population", "6", "--duration", "2", "--seed", "3", "--quiet"]


def log_rows(run: Path) -> list[dict]:
    with open(run / "log.csv") as handle:
        return [{k: v for k, v in r.items() if k != "elapsed_seconds"}
                for r in csv.DictReader(handle)]


def test_cli_and_api_write_the_same_log(tmp_path):
    """The snippet of the README, with the validation the CLI adds, gives the CLI's log."""
    generations, every = 3, 2
    assert main(["evolve", *SMALL, "--generations", str(generations), "--evaluations", "2",
                 "--validate-every", str(every), "--out", str(tmp_path / "cli")]) == 0
    body = somite.Body.build("worm")
    task = somite.Locomotion(terrain="hilly-1-10-rnd", duration=2.0, evaluations=2)
    ea = somite.GraphEA(body, population=6, seed=3)
    for _ in range(generations + 1):
        genomes = ea.ask()
        ea.tell(genomes, task.evaluate(genomes, rng=ea.rng_evaluation))
        if ea.generation % every == 0 or ea.generation == generations:
            ea.log[-1]["validation_velocity"] = task.validation_velocity(ea.best)
    from somite.experiments.logfile import format_cell

    # The snippet's task.evaluate does not count non-finite episodes (evaluate_counted does).
    uncounted = ("elapsed_seconds", "non_finite_episodes")
    api = [{k: format_cell(v) for k, v in row.items() if k not in uncounted} for row in ea.log]
    cli = log_rows(tmp_path / "cli")
    assert [row.pop("non_finite_episodes") for row in cli] == ["0"] * (generations + 1)
    assert api == cli
    assert [r["validation_velocity"] != "" for r in cli] == [True, False, True, True]
    best = somite.Genome.load(tmp_path / "cli" / "best.json")
    assert best == ea.best
    assert float(cli[-1]["validation_velocity"]) == float(mean_velocity(task.validate(best)))


def test_variation_does_not_depend_on_the_task():
    """Two tasks that draw differently from rng_evaluation leave the mutations alone."""
    body = somite.Body.build("worm")
    asked = []
    for extra_draws in (0, 1000):
        ea = somite.GraphEA(body, population=5, seed=1)
        for generation in range(3):
            genomes = ea.ask()
            ea.rng_evaluation.random(extra_draws)
            ea.tell(genomes, np.arange(len(genomes), dtype=float) * (generation + 1))
        asked.append(ea.ask())
    assert asked[0] == asked[1]
    assert somite.GraphEA(body, population=5, seed=2).ask() != somite.GraphEA(
        body, population=5, seed=1).ask()


def test_steppy_trains_on_steppy_terrains(tmp_path):
    rng = np.random.default_rng(0)
    drawn = parse_distribution("steppy-1-10-rnd").sample(rng, 20)
    assert all(t.name.startswith("steppy-1-10-") for t in drawn)
    assert len({t.name for t in drawn}) > 10
    for terrain in ("steppy-1-10-rnd", "hilly-1-10-rnd"):
        assert main(["evolve", *SMALL, "--generations", "1", "--terrain", terrain,
                     "--validate-every", "0", "--out", str(tmp_path / terrain)]) == 0
    steppy, hilly = (log_rows(tmp_path / t) for t in ("steppy-1-10-rnd", "hilly-1-10-rnd"))
    assert [r["best_velocity"] for r in steppy] != [r["best_velocity"] for r in hilly]


def test_slopes_are_drawn_between_0_and_10_degrees():
    rng = np.random.default_rng(0)
    for name, sign in (("uphill-rnd", 1), ("downhill-rnd", -1)):
        drawn = parse_distribution(name).sample(rng, 200)
        degrees = [math.degrees(math.atan((t.ys[-2] - t.ys[1]) / (t.xs[-2] - t.xs[1])))
                   for t in drawn]
        assert all(0 <= sign * d <= 10 + 1e-9 for d in degrees)
        assert max(sign * d for d in degrees) > 9 and min(sign * d for d in degrees) < 1
    flat = parse_distribution("flat")
    assert not flat.is_random and flat.sample(rng, 2)[0].name == "flat"


@pytest.mark.parametrize("terrain", ["bogus-rnd", "flat-rnd", "hilly-1-0-rnd", "hilly-10000",
                                     "hilly-1-10-10003"])
def test_unknown_or_held_out_terrain_is_refused_in_one_line(tmp_path, capsys, terrain):
    code = main(["evolve", *SMALL, "--terrain", terrain, "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and f"terrain='{terrain}'" in err
    assert not (tmp_path / "run").exists()


def test_evaluations_average_k_terrains_drawn_in_order():
    body = somite.Body.build("worm")
    genomes = [initial_genome(body, np.random.default_rng(s)) for s in (0, 1)]
    task = somite.Locomotion(duration=2.0, evaluations=3)
    fitness = task.evaluate(genomes, np.random.default_rng(7))
    rng = np.random.default_rng(7)
    terrains = task.terrains.sample(rng, 6)
    seeds = rng.integers(0, 2**32, 6)
    by_hand = [[somite.simulate(g, terrains[3 * i + k], duration=2.0, seed=int(seeds[3 * i + k]))
                .velocity for k in range(3)] for i, g in enumerate(genomes)]
    np.testing.assert_array_equal(fitness, np.mean(by_hand, axis=1))


def test_one_nan_rule_for_mean_velocity_and_rho(tmp_path, monkeypatch):
    """NaN on one terrain: NaN mean and NaN rho, in reassemble's and reoptimize's code alike."""
    assert math.isnan(mean_velocity([1.0, math.nan, 2.0]))
    assert mean_velocity([[1.0, 3.0], [math.nan, 1.0]], axis=1)[0] == 2.0
    assert math.isnan(rho(1.0, 2.0, math.nan)) and math.isnan(rho(math.nan, 1.0, 1.0))
    assert math.isnan(rho(1.0, 1.0, -1.0)) and rho(1.5, 1.0, 2.0) == 1.0
    reassembled = Transferability(("a", "b"), (1.0, math.nan), (1.0, 1.0), (2.0, 2.0))
    assert math.isnan(reassembled.rho) and reassembled.to_dict()["rho"] is None
    # reoptimize: the best NaN on one validation terrain gets rho NaN too
    body = somite.Body.build("worm")
    evolve(resolve({"population": 4, "generations": 1, "duration": 2.0, "validate_every": 0}),
           tmp_path / "run", start=initial_genome(body, np.random.default_rng(0)))
    one_nan = [1.0, math.nan]
    monkeypatch.setattr(reoptimize_module, "evaluate",
                        lambda genomes, terrains, config: np.array([one_nan] * len(genomes)))
    rows = reoptimize_module.transfer_curve(tmp_path / "run", [1.0, 2.0], None, 2)
    assert all(math.isnan(r["validation_velocity"]) and math.isnan(r["rho"]) for r in rows)


def test_bodies_must_match(tmp_path):
    worm, biped = somite.Body.build("worm"), somite.Body.build("biped")
    biped_genome = initial_genome(biped, np.random.default_rng(0))
    with pytest.raises(SomiteError, match="^shape="):
        somite.GraphEA(worm, start=biped_genome)
    with pytest.raises(SomiteError, match="^shape="):
        somite.Locomotion(duration=2.0, body=worm).evaluate([biped_genome],
                                                           np.random.default_rng(0))
    with pytest.raises(SomiteError, match="^shape='worm'"):
        evolve(resolve({"shape": "worm", "population": 4, "generations": 0}), tmp_path / "r",
               start=biped_genome)
    ea = somite.GraphEA(worm, population=4)
    ea.ask()
    with pytest.raises(SomiteError, match="^tell="):
        ea.tell(somite.GraphEA(worm, population=4, seed=1).ask(), np.zeros(4))  # not asked


def test_old_checkpoint_is_refused_in_one_line(tmp_path, capsys):
    args = ["evolve", *SMALL, "--generations", "1", "--out", str(tmp_path / "run")]
    assert main(args) == 0
    capsys.readouterr()  # the short episodes' warning (within the transient)
    path = tmp_path / "run" / "checkpoint.json"
    data = json.loads(path.read_text())
    path.write_text(json.dumps({**data, "version": 1}))
    assert main([*args, "--generations", "2", "--resume"]) == 2
    err = capsys.readouterr().err
    assert "version 1 cannot be resumed" in err and err.count("\n") == 1


def test_the_example_runs():
    namespace = runpy.run_path(str(ROOT / "examples" / "api_tour.py"))
    ea = namespace["ea"]
    assert ea.generation == 2 and len(ea.log) == 3
    assert namespace["validation"].shape == (10,)
    assert isinstance(namespace["outcome"], somite.Outcome)
