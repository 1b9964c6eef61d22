"""Advance some runs of the packed campaign on another machine, one without Dask (only Python,
NumPy and Numba; somite itself from this repository's src/), for a fixed time, and pack them.

    python reports/paper-rq1/elsewhere.py advance SECONDS OUT --tasks T1,T2 --threads N
                                           [--check TASK --check-threads M]
    python reports/paper-rq1/elsewhere.py compare LOG_THERE LOG_HERE

``advance`` unpacks paper-rq1.pack, runs each named task in a process of its own with N Numba
threads (a run's numbers do not depend on the machine or its threads), stops them all after
SECONDS (each loses the generations since its last checkpoint), and packs the campaign into
OUT/advanced.pack. With ``--check``, it also re-runs TASK from the pack's checkpoint in a copy
and leaves its log in OUT/check-log.csv: ``compare`` then says whether the rows computed there
are byte for byte those of this machine's log (every column but the wall time).

Back here, unpack OUT/advanced.pack beside the campaign and copy the advanced tasks' folders
into it while the campaign is not running them (tasks not yet started: their folders are new).
This is how the seed-0 ablation runs' first generations were computed on 2026-12-04 (README.md).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SRC = HERE.parents[1] / "src"
CLI = "import sys; from somite.cli import main; sys.exit(main(sys.argv[1:]))"
RUN = ("import json, sys; from somite.campaigns.work import run_task; "
       "run_task(sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3]))")
GRACE = 40
"""Seconds a stopped run has to end before it is killed."""


def advance(seconds: float, out: Path, tasks: list[str], threads: int, check: str | None,
            check_threads: int) -> None:
    start = time.time()
    env = dict(os.environ, PYTHONPATH=str(SRC), PYTHONUNBUFFERED="1")
    work = out / "work"
    shutil.rmtree(work, ignore_errors=True)
    copies = ["campaign"] + (["check"] if check else [])
    for name in copies:
        subprocess.run([sys.executable, "-c", CLI, "campaign", "unpack",
                        str(HERE / "paper-rq1.pack"), "--out", str(work / name)],
                       env=env, check=True)
    campaign = json.loads((work / "campaign" / "campaign.json").read_text())
    listed = {task["id"]: task for task in campaign["tasks"]}
    jobs = [(work / "campaign", task, threads) for task in tasks]
    if check:
        jobs.append((work / "check", check, check_threads))
    unknown = [task for _, task, _ in jobs if task not in listed]
    if unknown:  # before any run starts: a started one would be left running
        raise SystemExit(f"elsewhere.py: no task {unknown[0]!r} in the pack")
    processes = [subprocess.Popen(
        [sys.executable, "-c", RUN, str(folder), json.dumps(listed[task]), str(n)],
        env=env, start_new_session=True) for folder, task, n in jobs]
    while time.time() < start + seconds and any(p.poll() is None for p in processes):
        time.sleep(2)
    for p in processes:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
    for p in processes:
        try:
            p.wait(GRACE)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    subprocess.run([sys.executable, "-c", CLI, "campaign", "pack", str(work / "campaign"),
                    "--out", str(out / "advanced.pack")], env=env, check=True)
    if check:
        shutil.copy(work / "check" / check / "log.csv", out / "check-log.csv")
    print(f"advanced {', '.join(tasks)} for {time.time() - start:.0f} s into "
          f"{out / 'advanced.pack'}")


def compare(there: Path, here: Path) -> bool:
    """Whether every generation in both logs has the same row, but its wall time."""
    def rows(path: Path) -> dict[str, list[str]]:
        with path.open() as f:
            return {r["generation"]: [v for k, v in r.items() if k != "elapsed_seconds"]
                    for r in csv.DictReader(f)}

    a, b = rows(there), rows(here)
    common = sorted(set(a) & set(b), key=int)
    differ = [g for g in common if a[g] != b[g]]
    print(f"{len(common)} generations in both logs, {len(differ)} differ"
          + (f" (first: {differ[0]})" if differ else ""))
    return not differ


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    go = sub.add_parser("advance")
    go.add_argument("seconds", type=float)
    go.add_argument("out", type=Path)
    go.add_argument("--tasks", required=True)
    go.add_argument("--threads", type=int, default=1)
    go.add_argument("--check")
    go.add_argument("--check-threads", type=int, default=1)
    same = sub.add_parser("compare")
    same.add_argument("there", type=Path)
    same.add_argument("here", type=Path)
    args = parser.parse_args()
    if args.command == "advance":
        args.out.mkdir(parents=True, exist_ok=True)
        advance(args.seconds, args.out, args.tasks.split(","), args.threads, args.check,
                args.check_threads)
    elif not compare(args.there, args.here):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
