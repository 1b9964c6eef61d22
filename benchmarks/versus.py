"""`somite bench --no-scaling` of this tree against an earlier commit, in one sitting, runs
interleaved: the only comparison of kernel speed that means anything (a VM's speed drifts by
tens of percent between sittings, BENCHMARKS.md).

The earlier commit is checked out once into a git worktree (``.bench-trees/COMMIT``, ignored by
git) and keeps its own Numba cache there; both are run by this interpreter with ``PYTHONPATH``
pointing at the tree's ``src/``. Each tree's first call compiles or loads its kernels; that run
is reported apart. Prints JSON: every run's robot-control-steps a second, their medians per
shape and the ratio now / before.

    python benchmarks/versus.py [--base a9a43c1] [--runs 3] [--shapes worm,biped] [--threads 2]
                                [--clock cpu]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def tree(commit: str) -> Path:
    """A worktree of ``commit``, made once."""
    path = ROOT / ".bench-trees" / commit
    if not (path / "src" / "somite").is_dir():
        path.parent.mkdir(exist_ok=True)
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--force",
                        str(path), commit], check=True, capture_output=True)
    return path


# With --clock cpu: each population timed in the process's CPU seconds (time.process_time
# around somite.bench.bench_population, its set-up included, the same in both trees), which a
# machine loaded by other work does not stretch as it stretches wall time (one thread: the
# kernel runs in the calling thread).
_CPU = """
import json, time
from somite.bench import bench_population, compile_seconds
out = {"compile": compile_seconds()}
for shape in SHAPES:
    start = time.process_time()
    report = bench_population(shape, 96, DURATION)
    seconds = time.process_time() - start
    out[shape] = round(report["robots"] * report["steps_per_robot"] / seconds)
print(json.dumps(out))
"""


def bench(src: Path, shapes: str, threads: int, duration: float, clock: str = "wall") -> dict:
    """One `somite bench --no-scaling` of the tree whose sources are ``src`` (``clock``:
    "cpu" times it in CPU seconds, :data:`_CPU`)."""
    env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_NUM_THREADS": str(threads)}
    env.pop("NUMBA_CACHE_DIR", None)
    if clock == "cpu":
        code = _CPU.replace("SHAPES", repr(shapes.split(","))).replace("DURATION",
                                                                         repr(duration))
    else:
        code = ("import json, sys; from somite.bench import bench; "
                f"print(json.dumps(bench(shapes={shapes.split(',')!r}, duration={duration}, "
                "scaling=False)))")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True,
                         capture_output=True, text=True).stdout
    report = json.loads(out.strip().splitlines()[-1])
    if clock == "cpu":
        return report
    return {"compile": report["compile"],
            **{p["shape"]: p["robot_control_steps_per_second"] for p in report["populations"]}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="a9a43c1", help="the earlier commit")
    parser.add_argument("--runs", type=int, default=3, help="timed runs of each tree")
    parser.add_argument("--shapes", default="worm,biped")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--duration", type=float, default=30.0, help="episode length [s]")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="robot-control-steps per wall second, or per CPU second of the "
                        "process (a loaded machine; use with --threads 1)")
    args = parser.parse_args()
    if args.clock == "cpu" and args.threads != 1:
        parser.error("--clock cpu counts the process's CPU time: use --threads 1")
    trees = {"before": tree(args.base) / "src", "now": ROOT / "src"}
    first = {name: bench(src, args.shapes, args.threads, 1.0)["compile"]
             for name, src in trees.items()}
    runs: dict[str, list[dict]] = {name: [] for name in trees}
    for _ in range(args.runs):
        for name, src in trees.items():
            runs[name].append(bench(src, args.shapes, args.threads, args.duration, args.clock))
    shapes = args.shapes.split(",")
    median = {name: {s: statistics.median(r[s] for r in runs[name]) for s in shapes}
              for name in trees}
    print(json.dumps({
        "benchmark": "somite bench --no-scaling, interleaved, robot-control-steps per second",
        "clock": args.clock, "base": args.base, "threads": args.threads,
        "duration_s": args.duration,
        "first_call": first,
        "runs": {name: [{s: round(r[s]) for s in shapes} for r in runs[name]] for name in trees},
        "median": {name: {s: round(v) for s, v in m.items()} for name, m in median.items()},
        "now_over_before": {s: round(median["now"][s] / median["before"][s], 3) for s in shapes},
    }, indent=1))


if __name__ == "__main__":
    main()
