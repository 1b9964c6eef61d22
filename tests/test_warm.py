"""The first compile shared by two processes (``somite.tasks.warm``): the second compiles the
kernel the batch kernel calls, for the very types it calls it with, and a kernel that one
process is compiling inside its caller is loaded, not compiled again, by the other."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from somite.brain.controllers import Sine
from somite.sim import physics as ph
from somite.sim.config import SimConfig
from somite.sim.terrain import parse_terrain
from somite.tasks import lanes, warm
from somite.tasks.locomotion import simulate_batch

from .test_kernel_cache import _package_copy


@pytest.fixture
def batch(worm, monkeypatch):
    """A batch of three worms as run_batch makes it, with its groups, the batch kernel compiled
    (or loaded from the cache) first."""
    simulate_batch([worm], [parse_terrain("flat")], [Sine(1.0, 1.0, 0.0)],
                   SimConfig(duration=1 / 60))
    made = []
    monkeypatch.setattr(lanes, "run_groups", lambda *args: made.append(args))
    simulate_batch([worm] * 3, [parse_terrain("hilly-1-10-0")] * 3, [Sine(1.0, 1.0, 0.0)] * 3,
                   SimConfig(duration=1 / 60))
    return made[0]


def _cached_signatures(kernel) -> list:
    return [key[0] for key in kernel._cache._cache_file._load_index()]


def test_both_processes_compile_what_the_batch_kernel_calls(batch):
    assert warm.physics_signature(*batch)[0] in _cached_signatures(lanes.advance_group)
    assert warm.alone_signature(batch[0]) in _cached_signatures(ph.advance)


def test_a_warm_cache_starts_no_second_process(batch):
    assert warm.share_first_compile(*batch) is None


def test_a_callee_compiled_inside_its_caller_is_compiled_once_by_two_processes(tmp_path):
    """One process compiles graph_step (tanh inside it), the other tanh alone, both on one cold
    cache: whichever reaches tanh second loads it."""
    root = _package_copy(tmp_path)
    caller = ("import numpy as np\n"
              "from somite.brain.kernels import Graph, graph_step\n"
              "from somite.brain.kinds import SENSOR\n"
              "from somite._math import tanh\n"
              "none = np.zeros(0, np.int32)\n"
              "graph = Graph(1, np.array([SENSOR], np.int32), np.zeros(1, np.int32), 0, none,"
              " none, np.zeros(0), np.zeros(0))\n"
              "graph_step(graph, np.zeros(1), np.zeros(1), np.array([0.5]), np.zeros(1),"
              " False)\n")
    callee = "from somite._math import tanh\ntanh(0.5)\n"
    report = "print(sum(tanh.stats.cache_misses.values()))\n"
    environ = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "SOMITE_KERNEL_CACHE")}
    environ["PYTHONPATH"] = str(root)
    both = [subprocess.Popen([sys.executable, "-c", script + report], cwd=root, env=environ,
                             stdout=subprocess.PIPE, text=True) for script in (caller, callee)]
    outputs = [process.communicate(timeout=600)[0].split() for process in both]
    assert [process.returncode for process in both] == [0, 0]
    assert sum(int(out[-1]) for out in outputs) == 1
