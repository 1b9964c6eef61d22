"""Training terrains as named distributions: what a task draws a terrain from per evaluation.

- ``flat`` or any fixed terrain name (``hilly-1-10-42``, ``uphill-10``): always that terrain,
  no random draw;
- ``hilly-H-W-rnd`` / ``steppy-H-W-rnd``: ``hilly-H-W-SEED`` / ``steppy-H-W-SEED`` with SEED
  uniform in [0, 10000), as the authors' code draws its training terrains;
- ``uphill-rnd`` / ``downhill-rnd``: a slope uniform in {0, 0.5, ..., 10} degrees. The range
  covers the slopes of ``hilly-1-10`` (a segment rises N(0, 1 m) over about 10 m: 4.6 degrees
  on average, 95% of segments under 11 degrees), so a slope run asks for nothing a hilly run
  does not meet.

Validation terrains (``hilly-1-10-10000`` on) lie outside every training distribution. H and W
follow the terrain names' grammar (:mod:`somite.sim.terrain`): one spelling each, ``hilly-1-10-rnd``
and not ``hilly-1.0-10-rnd``, so that a fixed terrain's name is its terrain's one name too.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

import numpy as np

from ..errors import bad
from ..sim.terrain import (
    TERRAIN_HELP,
    Terrain,
    canonical,
    hilly,
    parse_terrain,
    read_sizes,
    slope,
    steppy,
)

N_TRAINING_SEEDS = 10000
"""Random hilly and steppy terrains use SEED in [0, 10000), as the original does."""
MAX_SLOPE_DEG = 10.0
SLOPE_STEP_DEG = 0.5
DISTRIBUTION_HELP = ("hilly-H-W-rnd, steppy-H-W-rnd, uphill-rnd, downhill-rnd, or one fixed "
                     f"terrain: {TERRAIN_HELP}")

_NUMBER = r"([0-9]+(?:\.[0-9]+)?)"
_SEEDED = re.compile(rf"^(hilly|steppy)-{_NUMBER}-{_NUMBER}-rnd$")
_SLOPED = re.compile(r"^(uphill|downhill)-rnd$")


@functools.lru_cache(maxsize=16384)
def _seeded_terrain(kind: str, height: float, width: float, seed: int) -> Terrain:
    # A hilly profile takes ~1 ms to build, a steppy one more; runs revisit the seeds often.
    return (hilly if kind == "hilly" else steppy)(height, width, seed)


@functools.lru_cache(maxsize=64)
def _slope_terrain(degrees: float) -> Terrain:
    kind = "uphill" if degrees >= 0 else "downhill"
    return slope(degrees, f"{kind}-{abs(degrees):g}")


@dataclass(frozen=True)
class TerrainDistribution:
    """A named distribution of terrains (see the module's docstring for the names).

    Attributes
    ----------
    name : str
        The name it was parsed from, e.g. ``hilly-1-10-rnd``.
    kind : str
        ``fixed``, ``hilly``, ``steppy``, ``uphill`` or ``downhill``.
    height, width : float
        H and W [m] of ``hilly`` and ``steppy`` (0 otherwise).
    """

    name: str
    kind: str
    height: float = 0.0
    width: float = 0.0

    @property
    def is_random(self) -> bool:
        return self.kind != "fixed"

    def sample(self, rng: np.random.Generator, n: int) -> list[Terrain]:
        """``n`` terrains, independent draws; a fixed distribution draws nothing from ``rng``."""
        if self.kind == "fixed":
            return [parse_terrain(self.name)] * n
        if self.kind in ("hilly", "steppy"):
            seeds = rng.integers(0, N_TRAINING_SEEDS, n)
            return [_seeded_terrain(self.kind, self.height, self.width, int(s)) for s in seeds]
        steps = rng.integers(0, int(MAX_SLOPE_DEG / SLOPE_STEP_DEG) + 1, n)
        sign = 1.0 if self.kind == "uphill" else -1.0
        return [_slope_terrain(sign * SLOPE_STEP_DEG * int(k)) for k in steps]


def parse_distribution(text: str) -> TerrainDistribution:
    """The distribution named ``text``; anything else is a one-line error naming it."""
    name = str(text).strip()
    match = _SEEDED.match(name)
    if match:
        kind = match.group(1)
        height, width, sizes = read_sizes(text, match.group(2), match.group(3))
        canonical(text, name, f"{kind}-{sizes}-rnd")
        return TerrainDistribution(name, kind, height, width)
    match = _SLOPED.match(name)
    if match:
        return TerrainDistribution(name, match.group(1))
    if name.endswith("-rnd"):
        raise bad("terrain", text, f"unknown terrain distribution; use {DISTRIBUTION_HELP}")
    # A fixed terrain: refuse a bad name now, not at the first evaluation. Its name is the
    # terrain's one name, which the task compares with the validation terrains'.
    return TerrainDistribution(parse_terrain(name).name, "fixed")


__all__ = ["DISTRIBUTION_HELP", "N_TRAINING_SEEDS", "TerrainDistribution", "parse_distribution"]
