"""Timing: the one home of somite's timing code.

The episode kernel on the paper's workload (``somite bench``, whose command line is
:mod:`somite.commands.bench`): a population of random graph controllers of about 200 nodes +
edges, on the paper's bodies with the paper's sensors, each robot on its own hilly terrain, 30 s
episodes. Compilation (or loading the compiled kernel from Numba's cache) is timed apart, on a
throw-away one-step run. The scripts of ``benchmarks/`` time their own workloads with the same
pieces (:func:`timed`, :func:`random_graph`, :func:`bench_population`) and print JSON.
"""

from __future__ import annotations

import os
import platform
import time

import numba
import numpy as np

from .brain.controllers import GraphArrays
from .brain.kinds import ACTUATOR, HIDDEN, KIND_DTYPE, SENSOR
from .sim.body import Body
from .sim.config import SimConfig
from .sim.system import compile_system
from .sim.terrain import hilly
from .tasks.lanes import run_group
from .tasks.locomotion import compile_controllers, run


def timed(work) -> float:
    """Seconds of wall time ``work()`` takes."""
    start = time.perf_counter()
    work()
    return time.perf_counter() - start


def random_graph(body: Body, size: int, rng: np.random.Generator) -> GraphArrays:
    """A random valid graph controller of about ``size`` nodes + edges for ``body``.

    Every reading and every voxel has its node; hidden nodes and edges make up the rest in the
    proportions of the paper's evolved controllers (worm: |V| 99, |E| 115 at |G| 216, so 46%
    nodes). Weights are large enough for the actuators to swing over their whole range.
    """
    n_readings = body.n_readings
    n_voxels = body.shape.n_voxels
    fixed = n_readings + n_voxels
    n_hidden = max(0, round(0.46 * size) - fixed)
    n_edges = max(1, size - fixed - n_hidden)
    kind = np.concatenate(
        [
            np.full(n_readings, SENSOR),
            np.full(n_voxels, ACTUATOR),
            np.full(n_hidden, HIDDEN),
        ]
    ).astype(KIND_DTYPE)
    ref = np.concatenate(
        [np.arange(n_readings), np.arange(n_voxels), np.full(n_hidden, -1)]
    ).astype(np.int32)
    sources = np.flatnonzero(kind != ACTUATOR)
    targets = np.flatnonzero(kind != SENSOR)
    src = rng.choice(sources, n_edges).astype(np.int32)
    dst = rng.choice(targets, n_edges).astype(np.int32)
    return GraphArrays(
        node_kind=kind,
        node_ref=ref,
        src=src,
        dst=dst,
        weight=rng.normal(0.0, 2.0, n_edges),
        bias=rng.normal(0.0, 0.5, n_edges),
    )


def bench_population(
    shape: str, n_robots: int = 96, duration: float = 30.0, size: int = 200, seed: int = 0,
    backend: str = "cpu",
) -> dict:
    """Time one population of ``n_robots`` random controllers of ``shape`` on hilly terrains
    (the CUDA backend's time includes copying the batch to the GPU and the trace back)."""
    rng = np.random.default_rng(seed)
    body = Body.build(shape)
    config = SimConfig(duration=duration)
    terrains = [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, n_robots)]
    graphs = [random_graph(body, size, rng) for _ in range(n_robots)]
    system = compile_system([body] * n_robots, terrains)
    controllers = compile_controllers(graphs, [body.shape.n_voxels] * n_robots)
    start = time.perf_counter()
    trace = run(system, controllers, config, list(range(n_robots)), backend=backend)
    wall = time.perf_counter() - start
    steps = n_robots * config.n_steps
    return {
        "shape": shape,
        "backend": backend,
        "robots": n_robots,
        "controller_size": int(np.mean([g.n_nodes + g.n_edges for g in graphs])),
        "steps_per_robot": config.n_steps,
        "wall_seconds": round(wall, 4),
        "robot_control_steps_per_second": round(steps / wall),
        "finite": bool((trace.status == 0).all()),
    }


def compile_seconds(backend: str = "cpu") -> dict:
    """Time of the first kernel call in this process: compiling, or loading from the cache
    (the CUDA kernel is compiled in every process)."""
    body = Body.build("worm")
    rng = np.random.default_rng(0)
    system = compile_system([body], [hilly(1.0, 10.0, 0)])
    controllers = compile_controllers([random_graph(body, 200, rng)], [body.shape.n_voxels])
    elapsed = timed(lambda: run(system, controllers, SimConfig(duration=1 / 60), [0],
                                backend=backend))
    if backend != "cpu":
        return {"compile_seconds": round(elapsed, 3)}
    stats = run_group.stats
    return {
        "compile_or_cache_load_seconds": round(elapsed, 3),
        "loaded_from_cache": bool(stats.cache_hits) and not stats.cache_misses,
    }


def bench(
    shapes=("worm", "biped"), n_robots: int = 96, duration: float = 30.0, scaling: bool = True,
    backend: str = "cpu",
) -> dict:
    """The full benchmark report (a JSON-ready dict)."""
    report = {
        "benchmark": "episode kernel, paper workload",
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "threads_used": numba.get_num_threads(),
            "python": platform.python_version(),
            "numba": numba.__version__,
            "numpy": np.__version__,
        },
        "compile": compile_seconds(backend),
        "populations": [bench_population(s, n_robots, duration, backend=backend)
                        for s in shapes],
    }
    if scaling:
        report["scaling_worm"] = [
            bench_population("worm", n, duration, backend=backend)
            for n in (n_robots // 4, n_robots // 2, n_robots)
        ]
    return report
