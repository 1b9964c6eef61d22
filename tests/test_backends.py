"""Every registered backend runs the CPU's episode code (cuda checked on numba-cuda's
simulator, as CI has no GPU), and lockstep runs write the logs their solo runs write."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from somite import evolve_lockstep
from somite.cli import main
from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.tasks.backends import BACKENDS, check_backend, cuda_unavailable

from .conftest import expect_error

# Two robots of different bodies and controllers, on their own hilly terrains, under both presets
# (the paper's for 0.5 s: they land at 0.43-0.45 s; the original code's sensors for 0.1 s, as the
# simulator is slow: 1.2 s a robot and control step): the CPU kernel called directly against the
# backend named in argv[1] through the registry (cuda: run by numba-cuda's simulator, plain
# Python, one thread per robot, as CI has no GPU), and against the Python stepper
# (somite.Episode), which runs the same start / control_step code and must agree bit for bit.
_BACKEND_SCRIPT = """
import json, sys, warnings
import numpy as np
from somite.bench import random_graph
from somite.sim.body import Body
from somite.sim.config import pack_params, preset
from somite.sim.sensors import noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.tasks.backends import BACKENDS
from somite.tasks.episode import new_trace
from somite.tasks.lanes import run_batch
from somite.tasks.locomotion import compile_controllers, outcomes, run
from somite.tasks.stepper import Episode

name = sys.argv[1]
reason = BACKENDS[name].unavailable()
if reason:
    print(json.dumps({"unavailable": reason}))
    sys.exit(0)
warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps, as it does compiled
rng = np.random.default_rng(1)
bodies = [Body.build("worm"), Body.build("biped")]
graphs = [random_graph(body, 40, rng) for body in bodies]
terrains = [hilly(1.0, 10.0, 7), hilly(1.0, 10.0, 8)]
system = compile_system(bodies, terrains)
ctrl = compile_controllers(graphs, [b.shape.n_voxels for b in bodies])
seeds = np.array([11, 12], dtype=np.uint64)


def gap(a, b):
    # Equal infinities, and NaN in both at the same place (diagnostics not measured yet), count
    # as equal; NaN in one only as infinitely far.
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    return float(np.nan_to_num(np.where(same, 0.0, np.abs(a - b)), nan=np.inf).max())


result = {}
for preset_name, duration in (("paper", 0.5), ("original-code", 0.1)):
    config = preset(preset_name, duration=duration)
    cpu = new_trace(2, config.n_steps, system, True)
    run_batch(system, ctrl, pack_params(config), noise_table(config), seeds, config.n_steps, cpu)
    other = run(system, ctrl, config, seeds, backend=name)
    stepped = Episode(graphs, terrains, config, seeds.tolist(), record=True, bodies=bodies).run()
    result[preset_name] = {
        "stepper": all(np.array_equal(a, b, equal_nan=True) for a, b in zip(cpu, stepped)),
        # Steps with a block on the ground, per robot.
        "landed": cpu.contact.any(axis=2).sum(axis=1).tolist(),
        "cpu": [o.velocity for o in outcomes(cpu, config)],
        "cpu_min_area": cpu.min_area.tolist(),
        "backend": [o.velocity for o in outcomes(other, config)],
        "com": float(np.abs(cpu.com - other.com).max()),
        "status": [cpu.status.tolist(), other.status.tolist()],
        "fields": {f: gap(getattr(cpu, f), getattr(other, f))
                   for f in ("max_speed", "min_area", "diagnostics", "non_finite")},
    }
if name == "cuda":  # its own table of the System fields indexed by terrain
    from somite.sim.system import System
    from somite.tasks.cuda_batch import TERRAIN_FIELDS
    result["terrain_fields"] = sorted(TERRAIN_FIELDS) == sorted(
        f for f in System._fields if f.startswith("terrain_") and f != "terrain_of")
print(json.dumps(result))
"""


@pytest.mark.parametrize("name", list(BACKENDS))
def test_every_backend_gives_the_cpu_kernels_numbers(name):
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run([sys.executable, "-c", _BACKEND_SCRIPT, name], env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    results = json.loads(done.stdout.splitlines()[-1])
    if "unavailable" in results:
        pytest.skip(f"backend {name!r} cannot run here: {results['unavailable']}")
    assert results.pop("terrain_fields", True)
    assert min(results["paper"]["landed"]) > 0  # the contacts are compared too
    for result in results.values():
        assert result["stepper"]
        assert result["status"] == [[0, 0], [0, 0]]
        assert result["cpu"] == pytest.approx(result["backend"], abs=1e-9)
        # Two different robots (v_x is 0 for both over a run shorter than the transient).
        assert abs(result["cpu_min_area"][0] - result["cpu_min_area"][1]) > 1e-6
        assert result["com"] < 1e-9
        assert all(gap < 1e-9 for gap in result["fields"].values()), result["fields"]


@pytest.mark.parametrize("name", list(BACKENDS))
def test_every_backend_is_in_the_command_lines_help(name, capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"{name}, {BACKENDS[name].help}" in text
    assert "{" + ",".join(BACKENDS) + "}" in text


def test_unknown_or_unavailable_backend_is_a_one_line_error(capsys):
    expect_error("backend", lambda: check_backend("gpu"))
    if cuda_unavailable() is None:
        pytest.skip("a CUDA GPU (or the simulator) is available here")
    expect_error("backend", lambda: check_backend("cuda"))
    for command in (["simulate", "--duration", "0.1"], ["bench", "--robots", "4"]):
        assert main([*command, "--backend", "cuda"]) == 2
        err = capsys.readouterr().err.strip()
        assert "error: backend='cuda': " in err and "\n" not in err


def _run_files(path: Path) -> dict:
    """A run directory's files, without the wall-clock times they record."""
    log = [line.split(",") for line in (path / "log.csv").read_text().splitlines()]
    timed = log[0].index("elapsed_seconds")
    checkpoint = json.loads((path / "checkpoint.json").read_text())
    checkpoint.pop("elapsed_seconds")
    return {
        "log": [row[:timed] + row[timed + 1:] for row in log],
        "bests": (path / "bests.jsonl").read_text(),
        "best": (path / "best.json").read_text(),
        "checkpoint": checkpoint,
    }


def test_lockstep_runs_write_what_solo_runs_write(tmp_path):
    small = {"population": 5, "generations": 3, "duration": 0.5, "validate_every": 2}
    configs = [
        resolve({**small, "seed": 3}),
        resolve({**small, "seed": 4, "shape": "biped"}),
        resolve({**small, "seed": 5, "generations": 1, "duration": 0.4}),
    ]
    for i, config in enumerate(configs):
        evolve(config, tmp_path / f"solo{i}")
    eas = evolve_lockstep([(c, tmp_path / f"together{i}") for i, c in enumerate(configs)])
    assert [ea.generation for ea in eas] == [3, 3, 1]
    for i in range(len(configs)):
        solo = _run_files(tmp_path / f"solo{i}")
        assert _run_files(tmp_path / f"together{i}") == solo
        assert len(solo["log"]) == configs[i].generations + 2
    assert _run_files(tmp_path / "together0") != _run_files(tmp_path / "together1")
