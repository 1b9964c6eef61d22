"""Where a control step's time goes in the CPU kernel, part by part.

The paper's workload (``somite bench``'s: random graph controllers of ~200 nodes + edges, each
robot on its own hilly terrain) is run on one thread, group by group, by the kernel's own
``somite.tasks.lanes.run_group`` with a ``spent`` array: the kernel then reads the CPU's cycle
counter between the parts of its step (``lanes.PARTS``), so what is timed is the step that runs,
not a copy of it (the counter's reads cost a little; the untimed batch is timed too, and "not
in a part" is the difference). For comparison, the episodes robot by robot (the one-robot
physics that the stepper's lone robots, the CUDA kernel and a group of one run) are timed
whole. Prints JSON: microseconds per robot and control step, each the least of ``--repeats``
runs (other work on the machine only ever adds).

    python benchmarks/passes.py [--shape worm] [--robots 24] [--duration 10] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from somite._cycles import now
from somite._jit import njit
from somite.bench import random_graph
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.sensors import lidar_rays, noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.tasks.episode import episode, robot_state, robot_work
from somite.tasks.work import new_work
from somite.tasks.lanes import PARTS, Batch, groups, run_group
from somite.tasks.locomotion import compile_controllers, run


@njit
def _robot_by_robot(system, ctrl, params, noise, seeds, n_steps, trace):
    """Each robot's whole episode alone (the one-robot physics): cycles."""
    rays = lidar_rays(params)
    t = now()
    for b in range(seeds.shape[0]):
        work = robot_work(system, ctrl, params, b)
        state = robot_state(system, b, params, work, rays)
        episode(b, Batch(system, ctrl, params, noise, seeds, n_steps, trace, work, rays), state)
    return now() - t


def _cycles_per_second() -> float:
    now()
    t0, c0 = time.perf_counter(), now()
    while time.perf_counter() - t0 < 0.2:
        pass
    return (now() - c0) / (time.perf_counter() - t0)


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--shape", default="worm")
    parser.add_argument("--robots", type=int, default=24)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--repeats", type=int, default=3, help="timed runs; each part's least")
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    body = Body.build(args.shape)
    config = SimConfig(duration=args.duration)
    terrains = [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, args.robots)]
    graphs = [random_graph(body, 200, rng) for _ in range(args.robots)]
    system = compile_system([body] * args.robots, terrains)
    ctrl = compile_controllers(graphs, [body.shape.n_voxels] * args.robots)
    seeds = np.arange(args.robots, dtype=np.uint64)
    params = pack_params(config)
    noise = noise_table(config)
    rays = lidar_rays(params)
    untimed = run(system, ctrl, config, list(range(args.robots)))

    numba.set_num_threads(1)
    per_second = _cycles_per_second()
    steps = args.robots * config.n_steps
    us = 1e6 / per_second / steps
    first, count = groups(system, threads=1)
    kernel = np.inf
    spent = np.full(len(PARTS), np.inf)
    for _ in range(args.repeats + 1):  # the first call compiles or loads
        trace = run(system, ctrl, config, list(range(args.robots)))
        t = time.perf_counter()
        run(system, ctrl, config, list(range(args.robots)))
        kernel = min(kernel, time.perf_counter() - t)
        timed = np.zeros(len(PARTS), dtype=np.uint64)
        batch = Batch(system, ctrl, params, noise, seeds, config.n_steps, trace,
                      new_work(system, ctrl, params), rays)
        for f, c in zip(first, count, strict=True):
            run_group(batch, f, c, timed)
        if not np.array_equal(trace.com, untimed.com, equal_nan=True):
            raise SystemExit("the timed kernel's trace differs from the untimed one's")
        # Each part's least over the repeats: other work on the machine only ever adds.
        spent = np.minimum(spent, timed.astype(float))
    alone = np.inf
    for _ in range(2):
        alone = min(alone, float(_robot_by_robot(system, ctrl, params, noise, seeds,
                                                 config.n_steps, trace)) * us)
    kernel_us = kernel * 1e6 / steps
    parts = {name: round(float(c) * us, 3) for name, c in zip(PARTS, spent, strict=True)}
    parts["not in a part (turning the blocks, the loops, the counter)"] = round(
        kernel_us - float(spent.sum()) * us, 3)
    return {
        "benchmark": "cost split of a control step, 1 thread",
        "shape": args.shape,
        "robots": args.robots,
        "groups": count.tolist(),
        "control_steps": config.n_steps,
        "substeps": int(params.substeps),
        "control_step_us": round(kernel_us, 3),
        "us_per_control_step": parts,
        "share": {name: round(v / kernel_us, 4) for name, v in parts.items()},
        "robot_by_robot_control_step_us": round(alone, 3),
    }


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
