"""What stepping an episode from Python costs: somite.Episode against the compiled loop.

A batch of worms with random graph controllers (the paper's size) on flat ground: the whole
episode run by the compiled loop (``run``, the cpu backend) and by the stepper (one ``step()``
a control step, and one ``step(actuation)`` a control step). Compile time (the first call in this
process: compiling, or loading Numba's on-disk cache) is reported apart from run time (the best
of ``--repeats`` further calls), on one thread and on all of Numba's. Prints JSON;
``stepper_overhead_per_control_step_us`` is the stepper's wall time per control step over the
compiled loop's.

    python benchmarks/stepper.py [--robots 24] [--duration 2] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json

import numba
import numpy as np

from somite._jit import on_disk
from somite.bench import random_graph, timed
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.system import compile_system
from somite.sim.terrain import parse_terrain
from somite.tasks.lanes import run_group
from somite.tasks.locomotion import compile_controllers, run
from somite.tasks.stepper import KERNELS, Episode


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--robots", type=int, default=24)
    parser.add_argument("--duration", type=float, default=2.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    body = Body.build("worm")
    rng = np.random.default_rng(0)
    graphs = [random_graph(body, 216, rng) for _ in range(args.robots)]
    config = SimConfig(duration=args.duration)
    terrain = parse_terrain("flat")
    bodies = [body] * args.robots
    seeds = list(range(args.robots))
    system = compile_system(bodies, [terrain] * args.robots, config.start_gap)
    ctrl = compile_controllers(graphs, [body.shape.n_voxels] * args.robots)
    actuation = rng.uniform(-1.0, 1.0, (args.robots, body.shape.n_voxels))

    def compiled():
        run(system, ctrl, config, seeds)

    def stepped(given=None):
        episode = Episode(graphs, terrain, config, seeds, bodies=bodies)
        while not episode.done:
            episode.step(given)

    cached = {"compiled_loop": on_disk(run_group),
              "stepper": all(on_disk(kernel) for kernel in KERNELS)}
    first = {"compiled_loop": timed(compiled), "stepper": timed(stepped)}
    n_steps = config.n_steps
    result = {
        "robots": args.robots,
        "shape": "worm",
        "controller_size": int(np.mean([g.n_nodes + g.n_edges for g in graphs])),
        "control_steps": n_steps,
        "repeats": args.repeats,
        "loaded_from_cache": cached,
        "first_call_seconds": {k: round(v, 3) for k, v in first.items()},
        "by_threads": {},
    }
    # One thread shows the cost of the calls themselves; all threads adds a fork and join of
    # the robots per control step, which the compiled loop pays once per episode.
    everyone = numba.get_num_threads()
    for threads in sorted({1, everyone}):
        numba.set_num_threads(threads)
        best = {
            "compiled_loop": min(timed(compiled) for _ in range(args.repeats)),
            "stepper": min(timed(stepped) for _ in range(args.repeats)),
            # A different workload (constant random poses): not comparable with the others.
            "stepper_given_actuation": min(timed(lambda: stepped(actuation))
                                           for _ in range(args.repeats)),
        }
        result["by_threads"][threads] = {
            "run_seconds": {k: round(v, 4) for k, v in best.items()},
            "per_control_step_us": {k: round(1e6 * v / n_steps, 1) for k, v in best.items()},
            "stepper_overhead_per_control_step_us": round(
                1e6 * (best["stepper"] - best["compiled_loop"]) / n_steps, 1),
        }
    numba.set_num_threads(everyone)
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
