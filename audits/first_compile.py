"""Where the first compile's time goes (issue 70, item 5): a new user's first command that
simulates, ``somite demo``, in a process whose Numba cache is empty, every compilation timed
from Numba's compile events.

    python audits/first_compile.py [--generations 1] [--out first-compile.json]

The demo runs at 1 generation by default (its kernels are the 60-generation demo's: a
specialisation depends on argument types, not sizes). A compile event nests the compilations
it triggers (a kernel's callees are compiled inside it), so each function gets its own time
("self": its event less the events inside it) beside the whole. CPU seconds are the process's
(all threads), so they mean the same on a loaded machine; wall seconds do not; the second
process that compiles a group's physics meanwhile (``somite.tasks.warm``) is counted apart,
its CPU seconds only (its compiles are not in the table), and so is the time this process
waited for its kernels: from these, the compile's length on two idle cores, where a process
runs as fast as its CPU seconds say (``two_idle_cores_s``: the longer of this process's CPU
before its wait and the second process's, then this process's after it). Prints JSON: the
totals, every function by its own CPU time, and how many specialisations each got.
The cache is a new temporary folder (``NUMBA_CACHE_DIR``): the repository's is not touched.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import resource
import sys
import tempfile
import threading
import time
from pathlib import Path

CACHE = tempfile.mkdtemp(prefix="somite-first-compile-")
os.environ["NUMBA_CACHE_DIR"] = CACHE  # before Numba is imported

from numba.core import event  # noqa: E402


class CompileTimes(event.Listener):
    """Each compile event's wall and CPU seconds, with those of the events nested in it."""

    def __init__(self) -> None:
        self.rows: list[dict] = []
        self._stacks: dict[int, list[list]] = {}
        self._lock = threading.Lock()

    def on_start(self, ev) -> None:
        stack = self._stacks.setdefault(threading.get_ident(), [])
        stack.append([time.perf_counter(), time.process_time(), 0.0, 0.0])

    def on_end(self, ev) -> None:
        stack = self._stacks[threading.get_ident()]
        wall0, cpu0, child_wall, child_cpu = stack.pop()
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        if stack:
            stack[-1][2] += wall
            stack[-1][3] += cpu
        function = ev.data["dispatcher"].py_func
        with self._lock:
            self.rows.append({
                "function": f"{function.__module__}.{function.__qualname__}",
                "signature": str(ev.data["args"])[:300], "depth": len(stack),
                "wall_s": wall, "cpu_s": cpu, "self_wall_s": wall - child_wall,
                "self_cpu_s": cpu - child_cpu, "cpu_from": cpu0, "cpu_to": cpu0 + cpu})


class Waits:
    """This process's waits for another's compile (``_jit``'s kernel locks), each with its CPU
    seconds at the start and the end; and the second process's CPU seconds."""

    def __init__(self, children0: float) -> None:
        self.rows: list[dict] = []
        self.second_cpu_s = 0.0
        self._children0 = children0
        self._flock = fcntl.flock

    def flock(self, handle, operation) -> None:
        wall0, cpu0 = time.perf_counter(), time.process_time()
        self._flock(handle, operation)
        wall = time.perf_counter() - wall0
        if operation == fcntl.LOCK_EX and wall > 0.1:
            self.rows.append({"lock": Path(getattr(handle, "name", "?")).name,
                              "wall_s": round(wall, 1), "cpu_at": cpu0})

    def finish_sharing(self, finish):
        def counted(child, at_once=False):
            finish(child, at_once)
            if child is not None:
                self.second_cpu_s = _children_cpu() - self._children0
        return counted


def _children_cpu() -> float:
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def summary(rows: list[dict], total_wall: float, total_cpu: float) -> dict:
    by_function: dict[str, dict] = {}
    for row in rows:
        entry = by_function.setdefault(row["function"], {"specialisations": 0, "self_cpu_s": 0.0,
                                                         "self_wall_s": 0.0})
        entry["specialisations"] += 1
        entry["self_cpu_s"] += row["self_cpu_s"]
        entry["self_wall_s"] += row["self_wall_s"]
    outer = [r for r in rows if r["depth"] == 0]
    ranked = sorted(by_function.items(), key=lambda kv: -kv[1]["self_cpu_s"])
    return {
        "command_wall_s": round(total_wall, 1), "command_cpu_s": round(total_cpu, 1),
        "compile_wall_s": round(sum(r["wall_s"] for r in outer), 1),
        "compile_cpu_s": round(sum(r["cpu_s"] for r in outer), 1),
        "compilations": len(rows), "functions": len(by_function),
        "outermost": [{k: (round(v, 1) if isinstance(v, float) else v) for k, v in r.items()
                       if k not in ("depth", "cpu_from", "cpu_to")} for r in outer],
        "lane_passes_self_cpu_s": round(sum(
            v["self_cpu_s"] for k, v in by_function.items() if ".lane_passes." in k), 1),
        "by_function": [{"function": k, "specialisations": v["specialisations"],
                         "self_cpu_s": round(v["self_cpu_s"], 2)} for k, v in ranked[:40]],
        "specialised_more_than_once": {k: v["specialisations"] for k, v in ranked
                                       if v["specialisations"] > 1},
    }


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generations", type=int, default=1)
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    from somite.cli import main as somite_main
    from somite.tasks import warm

    listener = CompileTimes()
    wall0, cpu0, children0 = time.perf_counter(), time.process_time(), _children_cpu()
    waits = Waits(children0)
    fcntl.flock, warm.finish_sharing = waits.flock, waits.finish_sharing(warm.finish_sharing)
    with tempfile.TemporaryDirectory() as demo, event.install_listener("numba:compile",
                                                                      listener):
        code = somite_main(["demo", "--out", str(Path(demo) / "demo"), "--generations",
                            str(args.generations), "--quiet"])
    if code != 0:
        sys.exit(f"somite demo exited with {code}")
    result = {"cache": CACHE, **summary(listener.rows, time.perf_counter() - wall0,
                                        time.process_time() - cpu0)}
    result["second_process_cpu_s"] = round(waits.second_cpu_s, 1)
    result["waits"] = [{"lock": w["lock"], "wall_s": w["wall_s"]} for w in waits.rows]
    outer = [r for r in listener.rows if r["depth"] == 0]
    if waits.rows and outer:
        # This process's compiling before its longest wait (for the second process's
        # kernel), and after it.
        wait = max(waits.rows, key=lambda w: w["wall_s"])["cpu_at"]
        before = sum(min(r["cpu_to"], wait) - r["cpu_from"] for r in outer
                     if r["cpu_from"] < wait)
        after = sum(r["cpu_to"] - max(r["cpu_from"], wait) for r in outer if r["cpu_to"] > wait)
        result["two_idle_cores_s"] = round(max(before, waits.second_cpu_s) + after, 1)
        result["this_process_before_after_cpu_s"] = [round(before, 1), round(after, 1)]
    if args.out:
        Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
