"""Throughput against batch size on CPU and GPU, and a lockstep slice of the paper's campaign.

1. robot-control-steps/s of the episode kernel for batches of 96 ... 100,000 robots, on the
   ``cpu`` and ``cuda`` backends: worm, paper sensors, random graph controllers of ~200 nodes +
   edges (as ``somite bench``), hilly terrains, 30 s episodes. Large batches reuse a pool of
   997 controllers and 1000 terrains (each robot its own noise seed, so no two robots move
   alike); a size whose projected time would overrun the budget is skipped, and said so.
2. 20 runs of the paper's EA (96 robots, parents re-evaluated, 30 s, worm) advanced in
   lockstep (:func:`somite.experiments.lockstep.evolve_lockstep`) for 100 generations, or as
   many as the budget allows, timed per generation.

The whole script keeps to ``--budget`` seconds (default 330) besides compiling and building
the batches (under 8 minutes in all on one H100 is the aim). Prints JSON and writes it to
``--out``. Usage (on a machine with an NVIDIA GPU and numba-cuda):

    PYTHONPATH=src python3 benchmarks/gpu.py --out gpu.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import tempfile
import time

import numba
import numpy as np

from somite.bench import random_graph
from somite.experiments.config import resolve
from somite.experiments.lockstep import evolve_lockstep
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.tasks.backends import cuda_unavailable
from somite.tasks.locomotion import compile_controllers, run

CPU_SIZES = (96, 960, 9600)
CUDA_SIZES = (96, 960, 4800, 9600, 20000, 50000, 100000)


class OutOfTime(Exception):
    pass


def batch(n: int, duration: float, pools: dict):
    body = pools["body"]
    terrains = [pools["terrains"][i % len(pools["terrains"])] for i in range(n)]
    graphs = [pools["graphs"][i % len(pools["graphs"])] for i in range(n)]
    system = compile_system([body] * n, terrains)
    controllers = compile_controllers(graphs, [body.shape.n_voxels] * n)
    return system, controllers, SimConfig(duration=duration)


def time_batch(n: int, backend: str, duration: float, pools: dict) -> dict:
    system, controllers, config = batch(n, duration, pools)
    start = time.perf_counter()
    trace = run(system, controllers, config, np.arange(n) + 1, backend=backend)
    wall = time.perf_counter() - start
    return {
        "backend": backend,
        "robots": n,
        "steps_per_robot": config.n_steps,
        "wall_seconds": round(wall, 4),
        "robot_control_steps_per_second": round(n * config.n_steps / wall),
        "finite_fraction": float((trace.status == 0).mean()),
    }


def sweep(backend: str, sizes, duration: float, pools: dict, deadline: float) -> list[dict]:
    """Time each size; skip those whose projected time (:func:`projected`) would pass the
    deadline."""
    results = []
    start = time.perf_counter()
    time_batch(4, backend, 1 / 60, pools)  # compile (or load) the kernel
    compile_seconds = time.perf_counter() - start
    timed = []
    for n in sizes:
        left = deadline - time.perf_counter()
        guess = projected(timed, n)
        if guess is not None and 1.5 * guess > left:
            results.append({"backend": backend, "robots": n, "skipped": "budget",
                            "projected_seconds": round(guess, 1)})
            continue
        result = time_batch(n, backend, duration, pools)
        timed.append((n, result["wall_seconds"]))
        results.append(result)
    return [{"backend": backend, "compile_seconds": round(compile_seconds, 2)}] + results


def projected(timed: list[tuple[int, float]], n: int) -> float | None:
    """The seconds a batch of n robots should take, from the (robots, seconds) timed so far:
    time grows as robots**k, k from the last two sizes but at least 1/2 (a GPU's time stays
    nearly flat until the card is full, so a straight line from a small batch skipped sizes
    that fit: on the H200, 960 robots took 10.0 s and 9,600 took 18.5 s, not 100) and at
    most 1."""
    if not timed:
        return None
    (n1, t1) = timed[-1]
    k = 1.0
    if len(timed) > 1:
        (n0, t0) = timed[-2]
        k = min(1.0, max(0.5, np.log(t1 / t0) / np.log(n1 / n0)))
    return t1 * (n / n1) ** k


def lockstep(backend: str, runs: int, generations: int, duration: float,
             deadline: float) -> dict:
    """``runs`` paper runs in lockstep; stops at the deadline (a partial result says so)."""
    configs = [resolve({"seed": seed, "generations": generations, "checkpoint_every": 1000,
                        "duration": duration}) for seed in range(runs)]
    times = []
    calls = [0, time.perf_counter()]

    def progress(ea, row):
        # Runs report in turn, so every ``runs``-th call ends a lockstep generation.
        calls[0] += 1
        if calls[0] % runs == 0:
            now = time.perf_counter()
            times.append(now - calls[1])
            calls[1] = now
            if now > deadline:
                raise OutOfTime

    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        try:
            evolve_lockstep([(c, f"{folder}/run{i}") for i, c in enumerate(configs)],
                            backend=backend, progress=progress)
            complete = True
        except OutOfTime:
            complete = False
    wall = time.perf_counter() - started
    per = float(np.median(times[1:])) if len(times) > 1 else float("nan")
    return {
        "backend": backend,
        "runs": runs,
        "generations_asked": generations,
        "generations_done": len(times) - 1,  # after generation 0
        "complete": complete,
        "wall_seconds": round(wall, 2),
        "generation_0_seconds": round(times[0], 3) if times else None,
        "median_generation_seconds": round(per, 3),
        "projected_seconds_for_asked": round(times[0] + per * generations, 1) if times else None,
        "robots_per_generation": runs * 2 * 96,
    }


def gpu_name() -> str:
    try:
        return subprocess.run(["nvidia-smi", "--query-gpu=name,memory.total",
                               "--format=csv,noheader"], capture_output=True, text=True,
                              timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="gpu.json")
    parser.add_argument("--budget", type=float, default=330.0, help="seconds, all parts")
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--generations", type=int, default=100)
    parser.add_argument("--cpu-sizes", default=",".join(map(str, CPU_SIZES)),
                        help="robots per cpu batch, comma-separated (empty: none)")
    parser.add_argument("--cuda-sizes", default=",".join(map(str, CUDA_SIZES)))
    args = parser.parse_args()
    start = time.perf_counter()
    reason = cuda_unavailable()
    report = {
        "benchmark": "episode kernel against batch size; lockstep campaign slice",
        "machine": {"gpu": gpu_name(), "cpu": platform.processor() or platform.machine(),
                    "cores": os.cpu_count(), "numba_threads": numba.get_num_threads(),
                    "numba": numba.__version__, "numpy": np.__version__,
                    "cuda": reason or "available"},
        "workload": ("worm, paper sensors, ~200-element random graphs, hilly-1-10, "
                     f"{args.duration:g} s"),
    }
    rng = np.random.default_rng(0)
    body = Body.build("worm")
    pools = {"body": body,
             "terrains": [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, 1000)],
             "graphs": [random_graph(body, 200, rng) for _ in range(997)]}
    budget_end = start + args.budget
    sweeps = []
    cuda_sizes = [int(n) for n in args.cuda_sizes.split(",") if n]
    cpu_sizes = [int(n) for n in args.cpu_sizes.split(",") if n]
    if reason is None and cuda_sizes:
        # Most of the budget for the GPU sweep and the lockstep slice.
        sweeps += sweep("cuda", cuda_sizes, args.duration, pools, start + 0.4 * args.budget)
    if cpu_sizes:
        sweeps += sweep("cpu", cpu_sizes, args.duration, pools, start + 0.55 * args.budget)
    report["throughput"] = sweeps
    if args.runs:
        report["lockstep"] = lockstep("cuda" if reason is None else "cpu", args.runs,
                                      args.generations, args.duration, budget_end)
    report["total_seconds"] = round(time.perf_counter() - start, 1)
    with open(args.out, "w") as handle:
        json.dump(report, handle, indent=2)
    return report


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
