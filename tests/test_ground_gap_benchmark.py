"""``benchmarks/ground_gap.py``: somite's side, step by step, is the episode it measures (the
same v_x and lowest corner as the whole episode's outcome), the summary's arithmetic, the
error lines; the driver's side needs a build of 2D-VSR-Sim's driver (env ``VSR``). No timing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from somite import evolve, resolve
from somite.brain.genome import Genome
from somite.sim.config import preset
from somite.sim.terrain import parse_terrain
from somite.tasks.validation import evaluate_outcomes

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import ground_gap  # noqa: E402

VSR = os.environ.get("VSR")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gap") / "worm"
    evolve(resolve({"shape": "worm", "preset": "paper", "population": 4, "generations": 3,
                    "duration": 2.0, "validate_every": 0}), folder)
    return folder


def test_somite_side_is_the_episode_it_measures(run):
    """Read step by step, the lowest corner's gap has the whole episode's minimum (its
    min_height) and the episode the same v_x: reading it changes nothing."""
    genome = Genome.load(run / "best.json")
    config = preset("paper", duration=ground_gap.DRIVER_DURATION,
                    transient=ground_gap.DRIVER_TRANSIENT, noise_sigma=0.0)
    terrain = parse_terrain("hilly-1-10-10003")
    gaps, vx = ground_gap.somite_gaps(genome, terrain, config)
    (outcome,), = evaluate_outcomes([genome], [terrain], config)
    steps = int(round(ground_gap.DRIVER_DURATION * ground_gap.CONTROL_HZ))
    assert len(gaps) == steps - ground_gap.SETTLE_STEPS
    assert gaps.min() == outcome.min_height
    assert vx == pytest.approx(outcome.velocity, rel=1e-12)
    # A walking robot's corners do not all sit at one height: the steps differ.
    assert np.unique(gaps).size > 100


def test_summary_of_a_gap_series():
    times = np.arange(121, 1801) / 60.0
    gaps = np.full(times.size, 0.01)
    gaps[times <= 5.0] = 0.02
    gaps[10] = -1.5  # at the start: not scored
    scored = np.flatnonzero(times > 5.0)
    gaps[scored[:20]] = -0.06
    gaps[scored[20]] = -0.3
    found = ground_gap.summary(gaps, times, 2.5)
    assert found["start_min"] == -1.5 and found["min"] == -0.3 and found["vx"] == 2.5
    assert found["below_5cm"] == pytest.approx(21 / scored.size)
    assert found["p1"] == pytest.approx(np.percentile(gaps[scored], 1))


def test_errors_are_one_line(run, tmp_path, capsys):
    assert ground_gap.main([str(tmp_path / "none"), "--vsr", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: vsr=") and len(err.strip().splitlines()) == 1
    (tmp_path / "empty").mkdir()
    with pytest.raises(Exception, match=r"^run=.*no best.json"):
        ground_gap.load_genome(str(tmp_path / "empty"))
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(Exception, match=r"^run=.*not a genome"):
        ground_gap.load_genome(str(tmp_path / "bad.json"))
    genome, config = ground_gap.load_genome(str(run))
    assert config["preset"] == "paper" and genome.n_nodes > 0


@pytest.mark.skipif(not VSR or not (Path(VSR) / "classes-main-sensors/CL.class").exists(),
                    reason="needs the paper-sensors driver in env VSR's classes-main-sensors")
@pytest.mark.skipif(not ground_gap.DEFAULT_EXPORT.exists(), reason="no export_genomes.py beside")
def test_end_to_end(run):
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks/ground_gap.py"), str(run),
                           "--terrains", "flat"], capture_output=True, text=True, cwd=ROOT,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    (found,) = json.loads(done.stdout)["runs"]
    cell = found["terrains"]["flat"]
    assert set(cell) == {"somite", *ground_gap.ENGINES}
    for side in cell.values():
        assert side["min"] <= side["p1"] and 0 <= side["below_5cm"] <= 1
