"""Episode-kernel throughput on the paper's workload; prints JSON (same as `somite bench`).

Usage: python benchmarks/kernel.py [--robots 96] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json

from somite.bench import bench

if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--robots", type=int, default=96)
    parser.add_argument("--duration", type=float, default=30.0)
    args = parser.parse_args()
    print(json.dumps(bench(n_robots=args.robots, duration=args.duration), indent=2))
