"""Evaluation of controllers on fixed validation terrains (transferability, ``somite evaluate``).

The validation set is :data:`VALIDATION_COUNT` terrains unless a command is told another count:
``hilly-1-10-SEED`` for SEED = 10000, 10001, ... Training draws hilly seeds from [0, 10000)
(docs/original-system.md section 1.5), so they are never training terrains.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..brain.compile import compile_genome
from ..brain.genome import Genome
from ..errors import bad
from ..limits import MAX_BATCH, MAX_VALIDATION, at_most
from ..sim.config import SimConfig
from ..sim.terrain import N_TRAINING_SEEDS, Terrain, hilly, hilly_name
from . import arguments
from .locomotion import Outcome, simulate_batch

VALIDATION_COUNT = 10
"""How many validation terrains a run logs its best's v_x on, and the default of every
command and campaign that measures on them (``--validation``)."""
VALIDATION_HEIGHT, VALIDATION_WIDTH = 1.0, 10.0
VALIDATION_SEED0 = N_TRAINING_SEEDS
"""Validation terrain i is ``hilly(VALIDATION_HEIGHT, VALIDATION_WIDTH, VALIDATION_SEED0 + i)``:
``hilly-1-10-10000``, ``hilly-1-10-10001``, ..., just past the training seeds."""


FRESH_SEED0 = 2 * N_TRAINING_SEEDS
"""Fresh terrain i is ``hilly(VALIDATION_HEIGHT, VALIDATION_WIDTH, FRESH_SEED0 + i)``:
``hilly-1-10-20000``, ...: past the training seeds (below 10000) and every validation terrain
(10000 to 10999 at most), for measuring a robot where nothing chose it."""


def check_count(count: int, name: str = "validation") -> int:
    """A number of validation terrains (or of terrains like them, the field ``name``): 1 to
    :data:`~somite.limits.MAX_VALIDATION`."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise bad(name, count, "must be a whole number at least 1")
    at_most(name, count, MAX_VALIDATION)
    return count


def validation_terrains(count: int = VALIDATION_COUNT) -> list[Terrain]:
    """The ``count`` fixed hilly validation terrains (hilly-1-10-10000, hilly-1-10-10001, ...)."""
    check_count(count)
    return [hilly(VALIDATION_HEIGHT, VALIDATION_WIDTH, VALIDATION_SEED0 + i)
            for i in range(count)]


def fresh_terrains(count: int) -> list[Terrain]:
    """The first ``count`` fresh terrains (:data:`FRESH_SEED0`), hilly like the validation
    ones."""
    check_count(count, "fresh")
    return [hilly(VALIDATION_HEIGHT, VALIDATION_WIDTH, FRESH_SEED0 + i) for i in range(count)]


def is_fresh_terrain(name: str) -> bool:
    """Whether the (canonical) terrain name is one of the fresh terrains any count can give."""
    prefix = hilly_name(VALIDATION_HEIGHT, VALIDATION_WIDTH, 0)[:-1]
    seed = name[len(prefix):] if name.startswith(prefix) else ""
    return seed.isdigit() and FRESH_SEED0 <= int(seed) < FRESH_SEED0 + MAX_VALIDATION


@dataclass(frozen=True)
class ValidationSet:
    """The first ``count`` validation terrains (checked: 1 to
    :data:`~somite.limits.MAX_VALIDATION`), built when first needed and then kept: a run, a
    re-optimisation or a report holds one and hands it on."""

    count: int = VALIDATION_COUNT

    def __post_init__(self) -> None:
        check_count(self.count)

    @property
    def names(self) -> list[str]:
        """The terrains' names, without building them."""
        return [hilly_name(VALIDATION_HEIGHT, VALIDATION_WIDTH, VALIDATION_SEED0 + i)
                for i in range(self.count)]

    @functools.cached_property
    def terrains(self) -> list[Terrain]:
        return validation_terrains(self.count)

    @classmethod
    def of(cls, validation: int | ValidationSet) -> ValidationSet:
        """``validation`` as a set: a count, or a set already built (kept with its terrains)."""
        return validation if isinstance(validation, ValidationSet) else cls(validation)


def evaluate(
    genomes: Sequence[Genome],
    terrains: Sequence[Terrain],
    config: SimConfig | None = None,
    seed: int = 0,
    backend: str = "cpu",
) -> np.ndarray:
    """v_x [m/s] of every genome on every terrain, shape (G, T), in one batch.

    NaN marks an episode that went non-finite.
    """
    outcomes = evaluate_outcomes(genomes, terrains, config, seed, backend)
    velocities = np.array([o.velocity for row in outcomes for o in row], dtype=np.float64)
    return velocities.reshape(len(genomes), len(terrains))


def evaluate_outcomes(
    genomes: Sequence[Genome],
    terrains: Sequence[Terrain],
    config: SimConfig | None = None,
    seed: int = 0,
    backend: str = "cpu",
) -> list[list[Outcome]]:
    """The :class:`Outcome` of every genome (rows) on every terrain (columns), in one batch."""
    config = arguments.sim_config("config", config)
    genomes = arguments.genomes("genomes", genomes, MAX_BATCH)
    terrains = checks.items("terrains", terrains, MAX_VALIDATION)
    terrains = [arguments.terrain(f"terrains[{i}]", t) for i, t in enumerate(terrains)]
    if len(genomes) * len(terrains) > MAX_BATCH:
        raise bad("genomes", f"{len(genomes)} genomes on {len(terrains)} terrains",
                  f"a batch has at most {MAX_BATCH:,} robots (somite.limits)")
    seed = checks.integer("seed", seed, 0, checks.SEED_END - 1)
    if not genomes or not terrains:
        return [[] for _ in genomes]
    bodies, worlds, controllers = [], [], []
    for genome in genomes:
        arrays = compile_genome(genome)
        for terrain in terrains:
            bodies.append(genome.body)
            worlds.append(terrain)
            controllers.append(arrays)
    outcomes, _ = simulate_batch(bodies, worlds, controllers, config, seeds=seed, backend=backend)
    n = len(terrains)
    return [outcomes[g * n : (g + 1) * n] for g in range(len(genomes))]


def fresh_noise(genome: Genome, terrain: Terrain, config: SimConfig | None = None,
                n: int = 5, seed: int = 0) -> np.ndarray:
    """v_x [m/s] of ``genome`` on ``terrain`` under ``n`` sensor-noise draws of its own.

    On one fixed terrain the noise is a run's only luck: a best of many robots is the one
    whose draw flattered it most. These draws come from ``SeedSequence(seed)``, not from a
    run's evaluation stream (whose seeds are uniform in [0, 2**32) as well: a coincidence is a
    one-in-a-billion event), so they say what the genome does, not what it drew."""
    arguments.genome("genome", genome)
    terrain = arguments.terrain("terrain", terrain)
    n = checks.integer("n", n, 1, MAX_VALIDATION)
    seed = checks.integer("seed", seed, 0, checks.SEED_END - 1)
    seeds = np.random.SeedSequence(seed).generate_state(n, dtype=np.uint32)
    arrays = compile_genome(genome)
    outcomes, _ = simulate_batch([genome.body] * n, [terrain] * n, [arrays] * n, config,
                           seeds=[int(s) for s in seeds])
    return np.array([o.velocity for o in outcomes], dtype=np.float64)
