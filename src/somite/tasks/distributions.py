"""Training terrains as named distributions: what a task draws a terrain from per evaluation.

- ``flat`` or any fixed terrain name (``hilly-1-10-42``, ``uphill-10``): always that terrain,
  no random draw;
- ``hilly-H-W-rnd`` / ``steppy-H-W-rnd``: ``hilly-H-W-SEED`` / ``steppy-H-W-SEED`` with SEED
  uniform in [0, 10000), as the authors' code draws its training terrains;
- ``uphill-rnd`` / ``downhill-rnd``: a slope uniform in {0, 0.5, ..., 10} degrees. The range
  covers the slopes of ``hilly-1-10`` (a segment rises N(0, 1 m) over about 10 m: 4.6 degrees
  on average, 95% of segments under 11 degrees), so a slope run asks for nothing a hilly run
  does not meet.

Validation terrains (``hilly-1-10-10000`` on) lie outside every training distribution. The
names are the terrain names' grammar (:data:`somite.sim.terrain.TERRAIN_KINDS`, where each
kind's draw is): one spelling each, ``hilly-1-10-rnd`` and not ``hilly-1.0-10-rnd``, so that a
fixed terrain's name is its terrain's one name too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..sim.terrain import (
    DISTRIBUTION_HELP,
    N_TRAINING_SEEDS,
    RANDOM,
    TERRAIN_KINDS,
    Terrain,
    drawn_terrain,
    parse_name,
    parse_terrain,
)

FIXED = "fixed"
"""The kind of a distribution that is one fixed terrain."""


@dataclass(frozen=True)
class TerrainDistribution:
    """A named distribution of terrains (see the module's docstring for the names).

    Attributes
    ----------
    name : str
        Its one name, e.g. ``hilly-1-10-rnd`` or ``flat``.
    kind : str
        ``fixed``, or the terrain kind it draws (``hilly``, ``steppy``, ``uphill``,
        ``downhill``: :data:`somite.sim.terrain.TERRAIN_KINDS`).
    values : tuple
        The numbers of its name but the drawn one (H and W for ``hilly-H-W-rnd``).
    terrain : Terrain or None
        The terrain of a fixed distribution, built once.
    """

    name: str
    kind: str
    values: tuple = ()
    terrain: Terrain | None = field(default=None, compare=False, repr=False)

    @property
    def is_random(self) -> bool:
        return self.kind != FIXED

    def sample(self, rng: np.random.Generator, n: int) -> list[Terrain]:
        """``n`` terrains, independent draws; a fixed distribution draws nothing from ``rng``."""
        if not self.is_random:
            return [self.terrain] * n
        return [drawn_terrain(self.kind, (*self.values, value))
                for value in TERRAIN_KINDS[self.kind].sample(rng, n)]


def parse_distribution(text: str) -> TerrainDistribution:
    """The distribution named ``text``; anything else is a one-line error naming it."""
    name = str(text).strip()
    if name.endswith(f"-{RANDOM}"):
        kind, values = parse_name(text, drawn=True)
        return TerrainDistribution(name, kind, values)
    # A fixed terrain: refuse a bad name now, not at the first evaluation. Its name is the
    # terrain's one name, which the task compares with the validation terrains'.
    terrain = parse_terrain(name)
    return TerrainDistribution(terrain.name, FIXED, (), terrain)


__all__ = ["DISTRIBUTION_HELP", "N_TRAINING_SEEDS", "TerrainDistribution", "parse_distribution"]
