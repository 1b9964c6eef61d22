"""The batch that every backend is checked on: two robots of different bodies and controllers,
on their own hilly terrains, under both presets (the paper's for 0.5 s: they land at
0.43-0.45 s; the original code's sensors for 0.1 s).

Run as ``python -m tests.backend_batch NAME OUT.npz`` it runs the batch on backend ``NAME`` and
saves its traces: the ``cuda`` backend runs so under numba-cuda's simulator (plain Python, one
thread per robot, 1.2 s a robot and control step), which must be switched on before Numba is
imported, hence in a process of its own. Only the backend runs there: the CPU kernel it is
compared with runs in the test's process, whose compiled kernels the suite shares (compiling
them again there, on a fresh clone's cold cache, took 160 of its 200 s).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from somite.bench import random_graph
from somite.sim.body import Body
from somite.sim.config import preset
from somite.sim.system import System, compile_system
from somite.sim.terrain import hilly
from somite.tasks.backends import BACKENDS
from somite.tasks.episode import Trace
from somite.tasks.locomotion import compile_controllers, run

CASES = (("paper", 0.5), ("original-code", 0.1))


def batch():
    """``(bodies, graphs, terrains, system, controllers, seeds)``, the same every call."""
    rng = np.random.default_rng(1)
    bodies = [Body.build("worm"), Body.build("biped")]
    graphs = [random_graph(body, 40, rng) for body in bodies]
    terrains = [hilly(1.0, 10.0, 7), hilly(1.0, 10.0, 8)]
    system = compile_system(bodies, terrains)
    ctrl = compile_controllers(graphs, [b.shape.n_voxels for b in bodies])
    return bodies, graphs, terrains, system, ctrl, np.array([11, 12], dtype=np.uint64)


def run_cases(name: str) -> dict[str, Trace]:
    """Backend ``name``'s trace of the batch under each case's preset."""
    *_, system, ctrl, seeds = batch()
    return {p: run(system, ctrl, preset(p, duration=d), seeds, backend=name) for p, d in CASES}


def save(name: str, out: str, arrays_of) -> None:
    """Save ``arrays_of(name)`` (name -> array) to ``out`` if backend ``name`` can run here;
    stdout's last line says which, as JSON, for :func:`run_elsewhere`."""
    reason = BACKENDS[name].unavailable()
    if reason:
        print(json.dumps({"unavailable": reason}))
        return
    warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps, as it does compiled
    np.savez(out, **arrays_of(name))
    print(json.dumps({"saved": out}))


def run_elsewhere(module: str, name: str, out: Path) -> Path:
    """Run ``python -m module name out`` (a module whose main calls :func:`save`) in a process
    of its own under numba-cuda's simulator; ``out``, or the test skipped if ``name`` cannot
    run there."""
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
    done = subprocess.run([sys.executable, "-m", module, name, str(out)], env=env,
                          cwd=Path(__file__).parents[1], capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    said = json.loads(done.stdout.splitlines()[-1])
    if "unavailable" in said:
        pytest.skip(f"backend {name!r} cannot run here: {said['unavailable']}")
    return out


def _arrays(name: str) -> dict:
    arrays = {f"{p}.{field}": value for p, trace in run_cases(name).items()
              for field, value in trace._asdict().items()}
    if name == "cuda":  # its own table of the System fields indexed by terrain
        from somite.tasks.cuda_batch import TERRAIN_FIELDS  # imports numba.cuda: only here
        arrays["terrain_fields"] = np.array(sorted(TERRAIN_FIELDS) == sorted(
            f for f in System._fields if f.startswith("terrain_") and f != "terrain_of"))
    return arrays


def main(name: str, out: str) -> None:
    save(name, out, _arrays)


if __name__ == "__main__":
    main(*sys.argv[1:])
