"""Kernel throughput against batch size and threads: ``somite bench``'s workload (random graph
controllers of ~200 nodes + edges, each robot on its own hilly terrain) for batches of 1, 8, 24,
96 and 384 robots, on 1 thread and on all of Numba's. Compile time (or the load from Numba's
cache) is reported apart, from a throw-away first call. Prints JSON: robot-control-steps per
second, the best of ``--repeats``.

    python benchmarks/throughput.py [--shape worm] [--duration 10] [--repeats 2]
                                    [--sizes 1 8 24 96 384]
"""

from __future__ import annotations

import argparse
import json

import numba

from somite.bench import bench_population, compile_seconds


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--shape", default="worm")
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 8, 24, 96, 384])
    args = parser.parse_args()
    everyone = numba.get_num_threads()
    result = {"benchmark": "kernel throughput by batch size and threads", "shape": args.shape,
              "duration_s": args.duration, "compile": compile_seconds(), "by_threads": {}}
    for threads in sorted({1, everyone}):
        numba.set_num_threads(threads)
        rows = []
        for size in args.sizes:
            runs = [bench_population(args.shape, size, args.duration)
                    for _ in range(args.repeats)]
            best = max(runs, key=lambda r: r["robot_control_steps_per_second"])
            rows.append({"robots": size, "wall_seconds": best["wall_seconds"],
                         "robot_control_steps_per_second":
                             best["robot_control_steps_per_second"]})
        result["by_threads"][threads] = rows
    numba.set_num_threads(everyone)
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
