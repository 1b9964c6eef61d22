"""A batch's arrays are freed when it is done: the kernels hold no reference to them afterwards
(a run of thousands of generations would otherwise grow by a batch's arrays each time)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

# Numba counts its runtime's allocations only when told so before it is imported, hence a
# process of its own. Each way of running a batch runs once to compile (or load) and warm up;
# then the count of live arrays must not change over three more.
_SCRIPT = """
import gc, json
from numba.core.runtime import rtsys
from somite.bench import bench_population
from somite.brain.controllers import Zero
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.tasks.stepper import Episode

worm = Body.build("worm")
ways = {
    "batch": lambda: bench_population("worm", n_robots=12, duration=0.2),
    "stepper": lambda: Episode([Zero()] * 3, "flat", SimConfig(duration=0.1),
                               bodies=[worm] * 3).run(),
}


def live():
    gc.collect()
    stats = rtsys.get_allocation_stats()
    return stats.mi_alloc - stats.mi_free


held = {}
for name, way in ways.items():
    way()
    before = live()
    for _ in range(3):
        way()
    held[name] = live() - before
print(json.dumps(held))
"""


def test_no_batch_leaves_arrays_behind():
    env = {**os.environ, "NUMBA_NRT_STATS": "1"}
    done = subprocess.run([sys.executable, "-c", _SCRIPT], env=env, capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.splitlines()[-1]) == {"batch": 0, "stepper": 0}
