"""The documented limits on sizes a user may ask for, checked where each value is built.

Each bound is far beyond the paper's values (30 s episodes, 96 robots, 3000 generations, bodies
of at most 10 voxels a side, 10 validation terrains) and far below what would take a machine's
memory or days of computing: a value past one is a one-line error, not a hang.
"""

from __future__ import annotations

from .errors import bad

MAX_DURATION = 600.0
"""An episode's length [s] (the paper's: 30 s)."""
MAX_POPULATION = 10_000
MAX_GENERATIONS = 1_000_000
MAX_EVALUATIONS = 1_000
"""Terrains per fitness evaluation."""
MAX_SHAPE_SIDE = 32
"""Voxels along either side of a body's grid."""
MAX_VALIDATION = 1_000
"""Validation terrains."""
MAX_STEPPED = 10_000
"""Robots of an :class:`~somite.tasks.stepper.Episode`, stepped from Python: a population."""
MAX_BATCH = 1_000_000
"""Robots of one batch given to the API (``simulate_batch``, ``evaluate_genomes``: genomes
times terrains); a batch is also refused when it would need more than half of the machine's
memory (:func:`somite.budget.check_batch`)."""
MAX_FRAMES = 1_000
"""Tiles of a time-lapse strip."""
MIN_FPS = 1.0
MAX_OMEGA = 1e100
"""The modularity bias omega (the paper's: 10)."""
MAX_OPERATOR_WEIGHT = 1e6
"""An operator's probability ``p_*``: they are relative weights (the paper's sum to 1), drawn
in proportion; bounded so that their sum cannot overflow to infinity."""
MAX_SIGMA = 1e3
"""The weight mutation's standard deviation (the paper's: 0.35): far past any useful value,
far below where a mutated weight would leave :data:`MAX_WEIGHT`."""
MAX_WEIGHT = 1e100
"""An edge's weight or bias (evolved ones stay within a few units): sums over any genome's
edges stay finite."""


def at_most(field: str, value, limit) -> None:
    """Refuse ``value`` above ``limit`` (the documented maximum of ``field``)."""
    if value > limit:
        raise bad(field, value, f"must be at most {limit:g} (somite.limits)")
MAX_INPUT_BYTES = 256 * 2**20
"""A file somite reads (genome, module, partition, checkpoint, configuration): 256 MiB; a
checkpoint of the paper's population is well under 1 MiB."""
