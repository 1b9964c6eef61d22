"""Re-optimisation of a reassembled robot and its transferability over generations.

The paper (section 6) re-evolves a reassembled genome G' with the same EA, starting from G' and
mutants of it, for 510 generations, and plots rho = v_x(best) / mean(v_x(donors)) along the way
(Figures 7, 8). Here every velocity in rho is measured on the same fixed validation terrains
(docs/decisions.md, "Transferability"), and the best of each generation is evaluated once per
distinct genome. Means and rho follow :mod:`somite.tasks.velocity` (NaN on any terrain: NaN).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from .._io import csv_text, write_atomic
from ..brain.genome import Genome
from ..errors import bad
from ..sim.config import SimConfig
from ..tasks.validation import VALIDATION_COUNT, ValidationSet, evaluate
from ..tasks.velocity import mean_velocity, rho
from .config import RunConfig
from .runner import Progress, RunDirectory, evolve

TRANSFER_COLUMNS = ("generation", "training_velocity", "validation_velocity", "rho")


def donor_velocities(donors: Sequence[Genome], config: SimConfig,
                     n_terrains: int | ValidationSet) -> list[float]:
    """Each donor's mean v_x [m/s] on the validation terrains (a count, or the set)."""
    terrains = ValidationSet.of(n_terrains).terrains
    velocities = evaluate(list(donors), terrains, config)
    return [float(v) for v in mean_velocity(velocities, axis=1)]


def transfer_curve(run: str | Path, donors: Sequence[float], config: SimConfig,
                   n_terrains: int | ValidationSet = VALIDATION_COUNT) -> list[dict]:
    """rho of every generation's best against the donors' mean velocities ``donors`` (empty:
    no rho), from ``bests.jsonl``, on the validation terrains (a count, or the set); written
    to ``transfer.csv``."""
    terrains = ValidationSet.of(n_terrains).terrains
    run_dir = RunDirectory(run)
    entries = [json.loads(line) for line in run_dir.file("bests.jsonl").read_text().splitlines()]
    thinned = next((e["generation"] for e in entries if "genome" not in e), None)
    if thinned is not None:  # `campaign pack` never thins a re-optimisation's; one by hand
        raise bad("bests", str(run_dir.file("bests.jsonl")), f"the best of generation "
                  f"{thinned} was thinned away; the transfer curve needs every best")
    keys = [json.dumps(e["genome"], sort_keys=True) for e in entries]
    distinct = list(dict.fromkeys(keys))
    genomes = [Genome.from_dict(json.loads(k)) for k in distinct]
    velocities = mean_velocity(evaluate(genomes, terrains, config), axis=1)
    by_key = dict(zip(distinct, velocities))
    rows = []
    for entry, key in zip(entries, keys):
        validation = float(by_key[key])
        rows.append({
            "generation": entry["generation"],
            "training_velocity": entry["velocity"],
            "validation_velocity": validation,
            "rho": rho(validation, *donors) if donors else None,
        })
    run_dir.record("transfer.csv")
    write_atomic(run_dir.file("transfer.csv"), csv_text(TRANSFER_COLUMNS, rows))
    return rows


def reoptimize(config: RunConfig, out: str | Path | RunDirectory, start: Genome,
               donors: Sequence[Genome] = (), n_terrains: int = VALIDATION_COUNT,
               resume: bool = False,
               force: bool = False, progress: Progress | None = None, backend: str = "cpu",
               force_physics: bool = False):
    """Re-evolve ``start`` into the run directory ``out`` (:func:`~.runner.evolve`), then write
    ``transfer.csv`` against the ``donors``. The directory stays locked until that is written,
    as it is part of the run (``out`` may be a :class:`RunDirectory` its caller has locked).
    ``backend`` is where the re-optimisation's episodes run (``cpu``, ``cuda``).
    Returns (the EA, the transfer rows, the donors' mean velocities)."""
    if not (isinstance(out, RunDirectory) and out.lock.held):
        with RunDirectory(out.path if isinstance(out, RunDirectory) else out).locked() as run_dir:
            return reoptimize(config, run_dir, start, donors, n_terrains, resume, force,
                              progress, backend, force_physics)
    sim = config.setup.sim
    # The run's own validation set when rho is measured on as many terrains: built once.
    validation = config.setup.validation
    if validation.count != n_terrains:
        validation = ValidationSet(n_terrains)
    ea = evolve(config, out, resume=resume, force=force, progress=progress, start=start,
                backend=backend, force_physics=force_physics)
    velocities = donor_velocities(donors, sim, validation) if donors else []
    rows = transfer_curve(out.path, velocities, sim, validation)
    return ea, rows, velocities
