"""The EA, run directories, reproducibility and resume (issue: the paper's EA)."""

from __future__ import annotations

import csv
import json
import math
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from somite.brain.genome import Genome
from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.config import GAConfig
from somite.evolution.ea import GraphEA, tournament, truncate
from somite.experiments.config import resolve
from somite.experiments.runner import LOG_COLUMNS, evolve
from somite.sim.body import Body
from somite.sim.partition import Partition
from somite.sim.terrain import parse_terrain
from somite.tasks.task import Locomotion
from somite.tasks.validation import fresh_noise

SMALL = {"shape": "worm", "population": 8, "generations": 4, "duration": 3.0, "seed": 3}


def rows(run: Path) -> list[dict]:
    with open(run / "log.csv") as handle:
        return list(csv.DictReader(handle))


def without_time(table: list[dict]) -> list[dict]:
    return [{k: v for k, v in row.items() if k != "elapsed_seconds"} for row in table]


def test_log_has_one_row_per_generation(tmp_path):
    config = resolve(SMALL)
    evolve(config, tmp_path / "run")
    table = rows(tmp_path / "run")
    assert list(table[0]) == list(LOG_COLUMNS)
    assert [int(r["generation"]) for r in table] == list(range(5))
    # 8 initial evaluations, then 8 offspring and the 8 parents again every generation.
    assert [int(r["evaluations"]) for r in table] == [8, 24, 40, 56, 72]
    assert table[0]["best_operator"] == "init" and table[0]["best_size"] == "92"
    bests = (tmp_path / "run" / "bests.jsonl").read_text().splitlines()
    assert len(bests) == 5
    last = json.loads(bests[-1])
    assert Genome.from_dict(last["genome"]) == Genome.load(tmp_path / "run" / "best.json")
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert resolve(saved) == config


def test_same_seed_same_log(tmp_path):
    for name in ("a", "b"):
        evolve(resolve(SMALL), tmp_path / name)
    assert without_time(rows(tmp_path / "a")) == without_time(rows(tmp_path / "b"))
    assert (tmp_path / "a" / "best.json").read_text() == (tmp_path / "b" / "best.json").read_text()
    evolve(resolve({**SMALL, "seed": 4}), tmp_path / "c")
    assert without_time(rows(tmp_path / "c")) != without_time(rows(tmp_path / "a"))


def test_original_code_preset_reevaluates_parents(tmp_path):
    evolve(resolve({**SMALL, "preset": "original-code", "generations": 2}), tmp_path / "run")
    assert [int(r["evaluations"]) for r in rows(tmp_path / "run")] == [8, 24, 40]


def test_weights_only_never_changes_topology(tmp_path):
    state = evolve(resolve({**SMALL, "weights_only": True}), tmp_path / "run")
    assert {(g.n_nodes, g.n_edges) for g in state.population.genomes} == {(52, 40)}
    assert {r["best_operator"] for r in rows(tmp_path / "run")} <= {"init", "mutate_edge"}


def test_omega_one_run_is_the_same_with_and_without_a_partition():
    """omega = 1 is neutral: a library caller giving the EA a partition gets the run, log and
    genomes (hidden nodes' voxels included) of a run without one."""
    body = Body.build("worm")
    task = Locomotion(duration=3.0)
    runs = []
    for partition in (None, Partition.preset("worm-halves", body.shape)):
        ea = GraphEA(body, population=8, seed=3, omega=1.0, p_add_node=0.6)
        ea.partition = partition
        for _ in range(4):
            genomes = ea.ask()
            ea.tell(genomes, task.evaluate(genomes, rng=ea.rng_evaluation))
        log = [{k: v for k, v in row.items() if k != "elapsed_seconds"} for row in ea.log]
        runs.append((json.dumps(log), [g.to_dict() for g in ea.population.genomes]))
    assert any(n.kind == "hidden" for g in ea.population.genomes for n in g.nodes)
    assert runs[0] == runs[1]


def test_tell_takes_genomes_that_went_through_pickle():
    """Evaluations farmed out (to Dask workers) come back as copies: tell takes genomes equal
    to those asked, and the run is the one told the very objects."""
    body = Body.build("worm")
    runs = []
    for copied in (False, True):
        ea = GraphEA(body, population=4, seed=3)
        for generation in range(3):
            genomes = ea.ask()
            told = pickle.loads(pickle.dumps(genomes)) if copied else genomes
            assert copied == all(a is not b for a, b in zip(told, genomes))
            ea.tell(told, np.arange(len(genomes), dtype=float) * (generation + 1))
        runs.append(([{k: v for k, v in r.items() if k != "elapsed_seconds"} for r in ea.log],
                     [g.to_dict() for g in ea.population.genomes]))
    assert runs[0] == runs[1]


def test_tell_refuses_genomes_that_were_not_asked():
    ea = GraphEA(Body.build("worm"), population=4, seed=3)
    genomes = ea.ask()
    other = GraphEA(Body.build("worm"), population=4, seed=4).ask()
    with pytest.raises(SomiteError, match=r"^tell='genomes\[2\]': not the genome the last ask"):
        ea.tell([*genomes[:2], other[2], genomes[3]], np.zeros(4))
    with pytest.raises(SomiteError, match="^tell='3 genomes': the last ask"):
        ea.tell(genomes[:3], np.zeros(3))
    ea.tell(genomes, np.zeros(4))  # the refusals changed nothing
    assert ea.generation == 0


def test_nan_counts_as_the_worst():
    fitness = np.array([np.nan, 0.1, 0.5, np.nan, -3.0])
    rng = np.random.default_rng(0)
    assert list(truncate(fitness, 3, rng)) == [2, 1, 4]
    # A tournament that draws (almost surely) everyone picks the best, never a NaN.
    assert {tournament(fitness, 60, rng) for _ in range(100)} == {2}
    # When every drawn fitness is NaN, a uniformly chosen drawn one wins: both can.
    winners = [tournament(np.array([np.nan, np.nan]), 3, rng) for _ in range(200)]
    assert set(winners) == {0, 1} and 60 < winners.count(0) < 140


def test_resume_after_sigkill_matches_uninterrupted_run(tmp_path):
    args = ["evolve", "--shape", "worm", "--population", "10", "--generations", "40",
            "--duration", "2", "--seed", "5", "--checkpoint-every", "6", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "whole")]) == 0
    killed = tmp_path / "killed"
    child = subprocess.Popen([sys.executable, "-m", "somite.cli", *args, "--out", str(killed)])
    deadline = time.time() + 600
    while time.time() < deadline and child.poll() is None:
        log = killed / "log.csv"
        if (killed / "checkpoint.json").exists() and log.exists():
            if len(log.read_text().splitlines()) >= 16:
                break
        time.sleep(0.01)
    if child.poll() is None:
        os.kill(child.pid, signal.SIGKILL)
    child.wait()
    assert child.returncode == -signal.SIGKILL, "the run finished before it could be killed"
    assert len(rows(killed)) < 41
    assert main([*args, "--out", str(killed), "--resume"]) == 0
    assert without_time(rows(killed)) == without_time(rows(tmp_path / "whole"))
    assert (killed / "best.json").read_text() == (tmp_path / "whole" / "best.json").read_text()
    whole_bests = (tmp_path / "whole" / "bests.jsonl").read_text()
    assert (killed / "bests.jsonl").read_text() == whole_bests


def test_toml_configuration(tmp_path):
    good = tmp_path / "good.toml"
    good.write_text('shape = "biped"\npopulation = 6\ngenerations = 1\nduration = 2\nomega = 10\n')
    assert main(["evolve", "--config", str(good), "--out", str(tmp_path / "run"), "--quiet"]) == 0
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["shape"] == "biped" and saved["omega"] == 10.0
    assert rows(tmp_path / "run")[0]["best_size"] == "80"  # 45 nodes + 35 edges


@pytest.mark.parametrize(
    "text, message",
    [
        ("populaton = 6\n", "config.populaton=6: unknown option"),
        ('population = "many"\n', "population='many': must be of type int"),
        ("omega = true\n", "omega=True: must be of type float"),
        ("omega = -1.0\n", "omega=-1.0: must be > 0"),
        ("generations = [\n", "not valid TOML"),
    ],
)
def test_bad_toml_is_one_line(tmp_path, capsys, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    code = main(["evolve", "--config", str(path), "--out", str(tmp_path / "run"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1
    assert not (tmp_path / "run").exists()


def test_resume_refuses_missing_or_damaged_checkpoint(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["evolve", "--out", str(run), "--resume", "--quiet"]) == 2
    assert "no config.json" in capsys.readouterr().err
    evolve(resolve(SMALL), run)
    (run / "checkpoint.json").write_text('{"format": "somite-checkpoint", "version": 1, "rng"')
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    assert main(["evolve", "--out", str(run), "--resume", "--quiet"]) == 2
    assert "damaged checkpoint" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before
    (run / "checkpoint.json").unlink()
    assert main(["evolve", "--out", str(run), "--resume", "--quiet"]) == 2
    assert "no checkpoint.json, but log.csv holds 5 generations" in capsys.readouterr().err
    assert {p.name for p in run.iterdir()} == set(before) - {"checkpoint.json"}


def test_existing_run_needs_resume_or_force(tmp_path, capsys):
    args = ["evolve", "--population", "6", "--generations", "1", "--duration", "2", "--quiet",
            "--out", str(tmp_path / "run")]
    assert main(args) == 0
    first = (tmp_path / "run" / "log.csv").read_text()
    assert main(args) == 2
    assert "use --resume or --force" in capsys.readouterr().err
    assert (tmp_path / "run" / "log.csv").read_text() == first
    assert main([*args, "--force", "--seed", "9"]) == 0
    assert (tmp_path / "run" / "log.csv").read_text() != first


def test_config_rejects_bad_values():
    with pytest.raises(SomiteError, match="^tournament=0"):
        GAConfig(tournament=0)
    with pytest.raises(SomiteError, match="^preset='fast'"):
        resolve({"preset": "fast"})
    with pytest.raises(SomiteError, match="^duration=nan"):
        resolve({"duration": math.nan})


def test_the_partition_option_keeps_its_name_modules():
    """GAConfig's field is ``partition_spec``; options, TOML and config.json say ``modules``."""
    ga = GAConfig.from_options({"modules": "worm-halves", "omega": 2.0})
    assert ga.partition_spec == "worm-halves"
    assert ga.partition(Body.build("worm").shape) == Partition.preset("worm-halves", "worm")
    data = ga.to_dict()
    assert data["modules"] == "worm-halves" and "partition_spec" not in data
    assert GAConfig.from_options(data) == ga
    assert resolve({"modules": "worm-halves", "omega": 2.0}).ga == ga
    with pytest.raises(SomiteError, match="^partition_spec='paper': unknown option"):
        GAConfig.from_options({"partition_spec": "paper"})
    with pytest.raises(SomiteError, match="^modules=3: must be of type str"):
        GAConfig.from_options({"modules": 3})


def test_a_short_run_improves(tmp_path):
    """The demo's setting, its first 10 generations: best v_x grows clearly (seeded, so exact:
    0.035 to 0.101 m/s on physics 1; the demo's 60 generations reach 2.4 m/s, as the README
    says). How fast it grows is luck that a change of rounding redraws (0.04 to 0.48 m/s on the
    physics before), so the test asks for a tripling, give or take."""
    from somite.commands.demo import DEMO

    config = resolve({**DEMO, "generations": 10})
    ea = evolve(config, tmp_path / "run")
    table = rows(tmp_path / "run")
    first, last = float(table[0]["best_velocity"]), float(table[-1]["best_velocity"])
    assert last > 2.5 * first and last > first + 0.05
    assert float(table[-1]["median_size"]) >= float(table[0]["median_size"])
    # The demo's rule: its training figure is what the robot does, within 20% of the mean
    # over 5 fresh noise draws (on one fixed terrain the noise is the only luck).
    fresh = fresh_noise(ea.best, parse_terrain(config.terrain), config.setup.sim, 5, seed=99)
    assert abs(last - fresh.mean()) <= 0.2 * abs(fresh.mean())


def test_evaluate_reports_every_validation_terrain(tmp_path, capsys):
    evolve(resolve(SMALL), tmp_path / "run")
    code = main(["evaluate", str(tmp_path / "run"), "--validation", "3", "--duration", "3",
                 "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    assert list(report["terrains"]) == [f"hilly-1-10-1000{i}" for i in range(3)]
    values = list(report["terrains"].values())
    assert report["mean_velocity"] == pytest.approx(sum(values) / 3)
    code = main(["evaluate", str(tmp_path / "run"), "--terrain", "flat", "--terrain",
                 "uphill-10", "--duration", "3", "--json"])
    assert list(json.loads(capsys.readouterr().out)["terrains"]) == ["flat", "uphill-10"]
    # --fresh N: the report's fresh terrains, the very episodes of naming them one by one
    code = main(["evaluate", str(tmp_path / "run"), "--fresh", "2", "--duration", "3",
                 "--seed", "1", "--json"])
    fresh = json.loads(capsys.readouterr().out)["terrains"]
    assert list(fresh) == ["hilly-1-10-20000", "hilly-1-10-20001"]
    code = main(["evaluate", str(tmp_path / "run"), "--terrain", "hilly-1-10-20000",
                 "--terrain", "hilly-1-10-20001", "--duration", "3", "--seed", "1", "--json"])
    assert json.loads(capsys.readouterr().out)["terrains"] == fresh
    assert main(["evaluate", str(tmp_path / "run"), "--fresh", "2", "--terrain", "flat"]) == 2
    assert "fresh=2: give --fresh or --terrain, not both" in capsys.readouterr().err
    assert main(["evaluate", str(tmp_path / "missing")]) == 2
    assert "no such file or run directory" in capsys.readouterr().err
