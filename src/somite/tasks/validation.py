"""Evaluation of controllers on fixed validation terrains (transferability, ``somite evaluate``).

Training draws hilly seeds from [0, 10000) (docs/original-system.md section 1.5); the validation
terrains use seeds from 10000 on, so they are never training terrains.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..brain.compile import compile_genome
from ..brain.genome import Genome
from ..errors import bad
from ..limits import MAX_VALIDATION, at_most
from ..sim.config import SimConfig
from ..sim.terrain import Terrain, hilly
from .locomotion import Outcome, simulate

VALIDATION_SEED0 = 10000


def check_count(count: int) -> int:
    """A number of validation terrains: 1 to :data:`~somite.limits.MAX_VALIDATION`."""
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise bad("validation", count, "must be a whole number at least 1")
    at_most("validation", count, MAX_VALIDATION)
    return count


def validation_terrains(count: int = 10) -> list[Terrain]:
    """The ``count`` fixed hilly validation terrains (hilly-1-10-10000, hilly-1-10-10001, ...)."""
    check_count(count)
    return [hilly(1.0, 10.0, VALIDATION_SEED0 + i) for i in range(count)]


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
    config = config or SimConfig()
    bodies, worlds, controllers = [], [], []
    for genome in genomes:
        arrays = compile_genome(genome)
        for terrain in terrains:
            bodies.append(genome.body)
            worlds.append(terrain)
            controllers.append(arrays)
    outcomes, _ = simulate(bodies, worlds, controllers, config, seeds=seed, backend=backend)
    n = len(terrains)
    return [outcomes[g * n : (g + 1) * n] for g in range(len(genomes))]


def fresh_noise(genome: Genome, terrain: Terrain, config: SimConfig | None = None,
                n: int = 5, seed: int = 0) -> np.ndarray:
    """v_x [m/s] of ``genome`` on ``terrain`` under ``n`` sensor-noise draws of its own.

    On one fixed terrain the noise is a run's only luck: a best of many robots is the one
    whose draw flattered it most. These draws come from ``SeedSequence(seed)``, not from a
    run's evaluation stream (whose seeds are uniform in [0, 2**32) as well: a coincidence is a
    one-in-a-billion event), so they say what the genome does, not what it drew."""
    seeds = np.random.SeedSequence(seed).generate_state(n, dtype=np.uint32)
    arrays = compile_genome(genome)
    outcomes, _ = simulate([genome.body] * n, [terrain] * n, [arrays] * n, config,
                           seeds=[int(s) for s in seeds])
    return np.array([o.velocity for o in outcomes], dtype=np.float64)
