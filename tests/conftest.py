"""Shared fixtures: the paper's bodies and quiet (noise-free) simulation settings."""

from __future__ import annotations

import fcntl
import functools
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from somite.cli import main
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.system import geometry


# A test compiles what it calls, when it calls it: tests that need no kernel run at once. A test
# worker (or a subprocess: a CLI run, a Dask worker) that needs a kernel another process is
# compiling waits for it and loads it from the cache (somite._jit's per-kernel lock), so no
# kernel is compiled twice at the same time. Only the tests of a module that starts processes
# get both kernels first (`kernels`): their subprocesses must find them cached, as under a file
# size limit or where their stderr is read line by line.


def _compile_batch_kernel() -> None:
    from somite.brain.controllers import Zero
    from somite.sim.terrain import parse_terrain
    from somite.tasks.locomotion import simulate_batch

    simulate_batch([Body.build("worm")], [parse_terrain("flat")], [Zero()],
                   SimConfig(duration=1 / 60))


def _compile_stepper() -> None:
    from somite.brain.controllers import Zero
    from somite.tasks.stepper import Episode

    Episode([Zero()], "flat", SimConfig(duration=1 / 60), bodies=[Body.build("worm")]).run()


@pytest.fixture(scope="session")
def kernels() -> None:
    """The batch kernel and the stepper compiled, or loaded from the cache, in this worker (the
    two workers start on different ones, each waiting for the other's)."""
    order = [_compile_batch_kernel, _compile_stepper]
    if int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:] or 0) % 2:
        order.reverse()
    for compile_kernel in order:
        compile_kernel()


@functools.cache
def _starts_processes(path: str) -> bool:
    text = Path(path).read_text()
    return "subprocess" in text or "LocalCluster" in text


@pytest.fixture(autouse=True)
def _kernels_for_subprocesses(request) -> None:
    """``kernels`` for the tests of a module that starts processes, unless it says
    ``KERNELS_FIRST = False`` (its subprocesses compile nothing of this checkout)."""
    path = getattr(request.module, "__file__", None)
    first = getattr(request.module, "KERNELS_FIRST", None)
    if first or (first is None and path and _starts_processes(path)):
        request.getfixturevalue("kernels")


@pytest.fixture(scope="session")
def smoke_campaign(tmp_path_factory) -> Path:
    """The smoke campaign as ``somite campaign run smoke`` runs it (a LocalCluster of 2 workers
    of 1 thread), run once for the whole suite: by the first test worker that asks, while the
    others wait for it (the folder is the session's, beside the workers' own). Read it; copy it
    before changing it."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    out, finished = shared / "smoke-campaign" / "smoke", shared / "smoke-campaign.finished"
    with open(shared / "smoke-campaign.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not finished.exists():
            shutil.rmtree(out.parent, ignore_errors=True)  # what a failed attempt left
            result = subprocess.run([sys.executable, "-m", "somite.cli", "campaign", "run",
                                     "smoke", "--out", str(out), "--workers", "2", "--threads",
                                     "1", "--quiet"], capture_output=True, text=True,
                                    timeout=900)
            assert result.returncode == 0, result.stderr
            finished.touch()
    return out


@pytest.fixture(scope="session")
def made_run(tmp_path_factory) -> Path:
    """A tiny finished run (worm, 4 robots, 1 generation of 1 s): copy it before changing it."""
    out = tmp_path_factory.mktemp("made") / "run"
    assert main(["evolve", "--shape", "worm", "--population", "4", "--generations", "1",
                 "--duration", "1", "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def worm() -> Body:
    return Body.build("worm")


@pytest.fixture(scope="session")
def biped() -> Body:
    return Body.build("biped")


def quiet(**options) -> SimConfig:
    """Settings without sensor noise, so that readings are exact geometry."""
    return SimConfig(noise_sigma=0.0).with_options(**options)


def voxel_geometry(body: Body, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (V, 2) and area ratios (V,) of a body's voxels from corner positions (P, 2)."""
    quads = pos[geometry(body).corners]  # (V, 4, 2)
    x, y = quads[..., 0], quads[..., 1]
    area = 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1)
    return quads.mean(axis=1), area / 9.0


def expect_error(field, build, kind=None):
    """``build()`` must raise a one-line SomiteError (or ``kind``, a subclass) whose message
    starts with ``field=``."""
    from somite.errors import SomiteError

    with pytest.raises(kind or SomiteError) as info:
        build()
    message = str(info.value)
    assert message.startswith(f"{field}="), message
    assert "\n" not in message
    return message


def evolved(shape: str, seed: int, steps: int = 40):
    """A controller grown by random mutations: hidden nodes and long-range edges."""
    from somite.evolution.operators import OperatorConfig, initial_genome, mutate

    grow = OperatorConfig(p_mutate_edge=0.2, p_add_edge=0.4, p_remove_edge=0.0, p_add_node=0.4,
                          p_remove_node=0.0)
    rng = np.random.default_rng(seed)
    genome = initial_genome(Body.build(shape), rng)
    for _ in range(steps):
        genome, _ = mutate(genome, rng, grow)
    return genome
