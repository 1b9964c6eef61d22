"""One task of a campaign, as a Dask worker runs it: write the task's folder, then done.json.

What is on disk is the truth. A task whose ``done.json`` exists is finished and not run again;
an evolve or re-optimisation task finds its run directory as a killed run left it and resumes
from its checkpoint (or starts again, before the first one), which for a seeded run gives the
same rows as a run never interrupted; a reassembly or discovery is cheap and is simply done
again (after removing the temporary files of writes the killed attempt did not finish). So a
task killed anywhere, with its worker or with the whole campaign, is retried by running it
again. Each task draws only from its own seed: the worker that runs it, and how many threads
it has, do not change a number. What a task of each kind does is its kind's ``run``
(:mod:`.kinds`).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from .._io import remove_temporary, write_atomic
from .kinds import TASK_KINDS
from .kinds.common import run_config
from .layout import DONE, read_done

__all__ = ["DONE", "run_config", "run_task"]


def run_task(directory: str, task: dict, threads: int = 1) -> dict:
    """Run ``task`` of the campaign in ``directory`` with ``threads`` Numba threads, unless it
    is finished (the campaign starts it once the tasks it needs are); returns its
    ``done.json``."""
    out = Path(directory) / task["path"]
    done = out / DONE
    record = read_done(out)
    if record is not None:
        return record
    # The campaign's lock keeps other campaigns out, and Dask runs a task once at a time: a
    # temporary file here is a killed attempt's, and would stay beside the redone outputs.
    remove_temporary(out)
    _threads(threads)
    start = time.perf_counter()
    steps = TASK_KINDS[task["kind"]].run(Path(directory), out, task["options"])
    record = {"task": task["id"], "elapsed_s": round(time.perf_counter() - start, 3),
              "robot_control_steps": int(steps),
              "finished": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    write_atomic(done, json.dumps(record) + "\n")
    return record


def _threads(threads: int) -> None:
    import numba

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
