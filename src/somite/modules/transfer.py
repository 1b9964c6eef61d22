"""Transferability of a reassembled robot (paper eq. 4).

rho = v(reassembled) / mean(v(donor 1), v(donor 2)), every v the mean v_x over the same fixed
validation terrains (docs/decisions.md, "Transferability"); the means and rho are
:mod:`somite.tasks.velocity`'s, with its one NaN rule (NaN on any terrain: NaN).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..brain.genome import Genome
from ..tasks.validation import evaluate, validation_terrains
from ..tasks.velocity import mean_velocity, rho
from .module import _finite_or_none

RHO_FLOOR = 0.1
"""[m/s] Below this mean donor v_x, rho is flagged as meaning little: it divides by a speed
that is noise (a still robot drifts up to ~0.005 m/s, a random initial controller moves ~0.01),
so donors at 0.02 m/s turn a reassembled robot's 1 m/s into rho = 50."""


@dataclass(frozen=True)
class Transferability:
    """rho and the velocities behind it, each the mean v_x [m/s] over the same terrains.

    Attributes
    ----------
    terrains : tuple of str
        Names of the validation terrains.
    v_reassembled, v_donor1, v_donor2 : tuple of float
        v_x on each terrain (NaN for an episode that went non-finite).
    """

    terrains: tuple[str, ...]
    v_reassembled: tuple[float, ...]
    v_donor1: tuple[float, ...]
    v_donor2: tuple[float, ...]

    @property
    def means(self) -> tuple[float, float, float]:
        """Mean v_x of the reassembled robot, donor 1 and donor 2."""
        return tuple(
            float(mean_velocity(v))
            for v in (self.v_reassembled, self.v_donor1, self.v_donor2)
        )

    @property
    def rho(self) -> float:
        return rho(*self.means)

    def to_dict(self) -> dict:
        mean_r, mean_1, mean_2 = self.means
        return {
            "terrains": list(self.terrains),
            "v_reassembled": _finite_or_none(mean_r),
            "v_donor1": _finite_or_none(mean_1),
            "v_donor2": _finite_or_none(mean_2),
            "rho": _finite_or_none(self.rho),
            "per_terrain": {
                "reassembled": [_finite_or_none(v) for v in self.v_reassembled],
                "donor1": [_finite_or_none(v) for v in self.v_donor1],
                "donor2": [_finite_or_none(v) for v in self.v_donor2],
            },
        }


def transferability(
    reassembled: Genome,
    donor1: Genome,
    donor2: Genome,
    terrains=None,
    config=None,
    seed: int = 0,
) -> Transferability:
    """Measure the three robots on the same terrains (default: the validation set,
    :data:`~somite.tasks.validation.VALIDATION_COUNT` terrains).

    ``config`` is a :class:`~somite.sim.config.SimConfig` (default: the paper's 30 s episodes).
    """
    terrains = validation_terrains() if terrains is None else list(terrains)
    velocity = evaluate([reassembled, donor1, donor2], terrains, config, seed)  # (3, T)
    rows = [tuple(float(v) for v in row) for row in velocity]
    return Transferability(tuple(t.name for t in terrains), *rows)


__all__ = [
    "Transferability",
    "rho",
    "transferability",
]
