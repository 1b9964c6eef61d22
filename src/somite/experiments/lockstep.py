"""Many evolutionary runs in lockstep: generation by generation, all their episodes in one batch.

One run has 96 robots a generation; a GPU needs tens of thousands in flight, and the CPU's
threads idle at the end of a small batch. Here every run asks its EA for its genomes, draws
its episodes from its own evaluation generator, and then the episodes of all runs that share
the simulator settings go to the simulator as one batch (validations too). A robot's outcome
does not depend on its batch, and each run draws only from its own generators, so every run
writes the same log, bests and checkpoints as it would alone (``elapsed_seconds`` aside).
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..evolution.ea import GraphEA
from ..tasks.backends import check_backend
from ..tasks.locomotion import simulate_batch
from ..tasks.task import Locomotion
from ..tasks.validation import evaluate as evaluate_on
from ..tasks.velocity import mean_velocity
from .config import RunConfig
from .runner import Progress, RunDirectory, finish_generation, open_run


@dataclass
class _Run:
    config: RunConfig
    directory: RunDirectory
    ea: GraphEA
    task: Locomotion


def evolve_lockstep(
    runs: Sequence[tuple[RunConfig, str | Path]],
    resume: bool = False,
    force: bool = False,
    backend: str = "cpu",
    progress: Progress | None = None,
) -> list[GraphEA]:
    """Run (or resume) the runs ``(config, run directory)`` together; their EAs at the end.

    Each run is what :func:`~somite.experiments.runner.evolve` would make of it alone, in its
    own locked directory; runs may differ in anything (their episodes are batched by
    simulator settings). ``progress`` is called after every generation of every run.
    """
    check_backend(backend)
    with ExitStack() as stack:
        every = []
        for config, out in runs:
            directory = stack.enter_context(RunDirectory(out).locked())
            ea = open_run(config, directory, resume, force, None)
            every.append(_Run(config, directory, ea, config.task(ea.body, backend)))
        active = every
        while active := [r for r in active if r.ea.generation < r.config.generations]:
            asked = [r.ea.ask() for r in active]
            fitness, non_finite = _evaluate_together(active, asked, backend)
            rows = [r.ea.tell(genomes, f, non_finite=n)
                    for r, genomes, f, n in zip(active, asked, fitness, non_finite)]
            due = [i for i, r in enumerate(active) if r.config.validation_due(r.ea.generation)]
            for i, velocity in zip(due, _validate_together([active[i] for i in due], backend)):
                rows[i]["validation_velocity"] = velocity
            for r, row in zip(active, rows):
                finish_generation(r.ea, row, r.directory, r.config, progress)
    return [r.ea for r in every]


def _evaluate_together(runs: list[_Run], asked: list,
                       backend: str) -> tuple[list[np.ndarray], list[int]]:
    """Each run's fitness of its asked genomes, and how many of its episodes had a non-finite
    step: one batch per distinct simulator setting."""
    episodes = [r.task.episodes(genomes, r.ea.rng_evaluation) for r, genomes in zip(runs, asked)]
    fitness: list[np.ndarray | None] = [None] * len(runs)
    non_finite = [0] * len(runs)
    for sim in {r.task.sim for r in runs}:
        members = [i for i, r in enumerate(runs) if r.task.sim == sim]
        batch = [episodes[i] for i in members]
        outcomes, _ = simulate_batch(
            [b for e in batch for b in e.bodies], [t for e in batch for t in e.terrains],
            [c for e in batch for c in e.controllers], sim,
            np.concatenate([e.seeds for e in batch]), backend=backend,
        )
        start = 0
        for i, e in zip(members, batch):
            stop = start + len(e.seeds)
            fitness[i] = runs[i].task.fitness([o.velocity for o in outcomes[start:stop]])
            non_finite[i] = int(runs[i].task.non_finite(outcomes[start:stop]).sum())
            start = stop
    return fitness, non_finite


def _validate_together(runs: list[_Run], backend: str) -> list[float]:
    """Each run's best's mean v_x on its validation terrains, batched like the training."""
    result: list[float] = [float("nan")] * len(runs)
    for sim in {r.task.sim for r in runs}:
        for terrains in {tuple(t.name for t in r.task.validation_terrains) for r in runs}:
            members = [i for i, r in enumerate(runs) if r.task.sim == sim and tuple(
                t.name for t in r.task.validation_terrains) == terrains]
            if not members:
                continue
            velocities = evaluate_on([runs[i].ea.best for i in members],
                                     runs[members[0]].task.validation_terrains, sim,
                                     backend=backend)
            for i, row in zip(members, velocities):
                result[i] = float(mean_velocity(row))
    return result
