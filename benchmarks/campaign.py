"""Campaign throughput against the kernel's: is Dask, and the Python around the kernel, cheap?

Runs ``somite bench``'s workload (96 random controllers, worm and biped, 30 s episodes, all of
this machine's threads), then a campaign of evolve runs only (biped and worm x ``--seeds``,
``--generations`` of the paper's population and episodes) on the default LocalCluster, and
prints both in robot-control-steps per second, as JSON. The campaign's figure is the steps of
its evolve tasks (their ``done.json``: training and validation episodes) over the campaign's
wall time, Dask's start and stop included. Run it on a quiet machine: both figures are timings.

Usage: python benchmarks/campaign.py [--seeds 2] [--generations 10] [--population 96]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from somite.bench import bench
from somite.campaigns.directory import document, prepare
from somite.campaigns.executor import execute, sizing
from somite.campaigns.expansion import expand
from somite.campaigns.spec import parse


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--generations", type=int, default=10)
    parser.add_argument("--population", type=int, default=96)
    parser.add_argument("--workers", type=int)
    parser.add_argument("--threads", type=int)
    args = parser.parse_args()
    kernel = bench(("worm", "biped"), scaling=False)
    kernel_rate = sum(p["robot_control_steps_per_second"] for p in kernel["populations"]) / 2
    campaign = parse({
        "defaults": {"generations": args.generations, "population": args.population},
        "experiments": {"rq1": {"kind": "evolve", "shapes": ["biped", "worm"],
                                "seeds": args.seeds}},
    }, name="throughput", source="benchmarks/campaign.py")
    tasks = expand(campaign)
    workers, threads = sizing(args.workers, args.threads)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "campaign"
        doc = prepare(out, document(campaign, tasks), resume=False)
        start = time.perf_counter()
        outcome = execute(out, doc, workers=workers, threads=threads)
        wall = time.perf_counter() - start
        if outcome.failed:
            raise SystemExit(f"campaign failed: {outcome.failed}")
        steps = sum(json.loads((out / t["path"] / "done.json").read_text())[
            "robot_control_steps"] for t in tasks)
        busy = sum(json.loads((out / t["path"] / "done.json").read_text())["elapsed_s"]
                   for t in tasks)
    rate = steps / wall
    return {
        "benchmark": "campaign throughput vs somite bench",
        "machine": kernel["machine"],
        "kernel": {"robot_control_steps_per_second": round(kernel_rate),
                   "populations": kernel["populations"]},
        "campaign": {"runs": len(tasks), "generations": args.generations,
                     "population": args.population, "workers": workers,
                     "threads_per_task": threads, "robot_control_steps": steps,
                     "wall_seconds": round(wall, 2), "task_seconds": round(busy, 2),
                     "robot_control_steps_per_second": round(rate)},
        "campaign_over_kernel": round(rate / kernel_rate, 3),
    }


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
