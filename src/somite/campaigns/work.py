"""One task of a campaign, as a Dask worker runs it: write the task's folder, then done.json.

What is on disk is the truth. A task whose ``done.json`` exists is finished and not run again;
an evolve or re-optimisation task finds its run directory as a killed run left it and resumes
from its checkpoint (or starts again, before the first one), which for a seeded run gives the
same rows as a run never interrupted; a reassembly or discovery is cheap and is simply done
again (after removing the temporary files of writes the killed attempt did not finish). So a
task killed anywhere, with its worker or with the whole campaign, is retried by running it
again. Each task draws only from its own seed: the worker that runs it, and how many threads
it has, do not change a number.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from .._io import remove_temporary, write_atomic
from ..sim.config import CONTROL_HZ
from .tasks import RUN_EXTRAS, run_steps

DONE = "done.json"


def run_task(directory: str, task: dict, threads: int = 1, *needed) -> dict:
    """Run ``task`` of the campaign in ``directory`` with ``threads`` Numba threads, unless it
    is finished; returns its ``done.json``. ``needed`` (the results of the tasks it needs) is
    how Dask orders it after them, and is not used."""
    out = Path(directory) / task["path"]
    done = out / DONE
    if done.is_file():
        return json.loads(done.read_text(encoding="utf-8"))
    # The campaign's lock keeps other campaigns out, and Dask runs a task once at a time: a
    # temporary file here is a killed attempt's, and would stay beside the redone outputs.
    remove_temporary(out)
    _threads(threads)
    start = time.perf_counter()
    steps = _RUNNERS[task["kind"]](Path(directory), out, task["options"])
    record = {"task": task["id"], "elapsed_s": round(time.perf_counter() - start, 3),
              "robot_control_steps": int(steps),
              "finished": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    write_atomic(done, json.dumps(record) + "\n")
    return record


def _threads(threads: int) -> None:
    import numba

    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))


def run_config(options: dict):
    """The :class:`RunConfig` of an evolve or re-optimisation task's options."""
    from ..experiments.config import resolve

    return resolve({k: v for k, v in options.items() if k not in RUN_EXTRAS})


def _evolve(root: Path, out: Path, options: dict) -> int:
    from ..experiments.runner import evolve

    ea = evolve(run_config(options), out, resume=True)
    return run_steps(options, ea.generation)


def _reoptimize(root: Path, out: Path, options: dict) -> int:
    from ..brain.genome import Genome
    from ..experiments.reoptimize import reoptimize

    start = Genome.load(root / options["start"] / "reassembled.json")
    donors = [Genome.load(root / d / "best.json") for d in options["donors"]]
    ea, _, _ = reoptimize(run_config(options), out, start, donors, options["validation"],
                          resume=True)
    return run_steps(options, ea.generation)


def _reassemble(root: Path, out: Path, options: dict) -> int:
    from ..brain.genome import Genome
    from ..experiments.reassembly import write_reassembly
    from ..sim.config import preset

    genomes = [Genome.load(root / d / "best.json") for d in options["donors"]]
    partitions = [str(root / p) if p.endswith(".json") else p for p in options["partitions"]]
    sim = preset(options["preset"], duration=options["duration"],
                 transient=options["transient"])
    write_reassembly(out, genomes, options["donors"], partitions, sim,
                     receiver_shape=options["receiver_shape"], take=options["take"],
                     validation=options["validation"], seed=options["seed"],
                     preset=options["preset"])
    return 3 * options["validation"] * int(round(options["duration"] * CONTROL_HZ))


def _discover(root: Path, out: Path, options: dict) -> int:
    from ..brain.genome import Genome
    from ..experiments.discovery import write_discovery

    genome = Genome.load(root / options["genome"] / "best.json")
    write_discovery(out, genome, options["genome"], options["b_min"], options["b_max"])
    return 0


_RUNNERS = {"evolve": _evolve, "reoptimize": _reoptimize, "reassemble": _reassemble,
            "discover": _discover}
