"""A robot's velocity over several terrains, and transferability: one NaN rule for both.

The rule: an episode that went non-finite gives v_x = NaN, and a mean over terrains that
includes one is NaN too, reported as such (``null`` in JSON). A robot that blows up on one
terrain in ten is not a robot whose velocity is the mean of the other nine. ``reassemble``,
``reoptimize``, ``evaluate``, ``assemble``, training with ``--evaluations K`` and the
``validation_velocity`` column of ``log.csv`` all use these two functions.

Pure NumPy: importing this module loads no simulator.
"""

from __future__ import annotations

import math

import numpy as np


def mean_velocity(velocities, axis: int = -1) -> np.ndarray | float:
    """Mean v_x [m/s] over ``axis`` (the terrains), NaN where any terrain's v_x is NaN.

    ``velocities`` of shape (..., T) gives shape (...); a 1-D input gives a float. An empty
    axis gives NaN.
    """
    values = np.asarray(velocities, dtype=np.float64)
    if values.shape[axis] == 0:
        mean = np.full(np.delete(values.shape, axis), np.nan)
    else:
        mean = values.mean(axis=axis)  # NaN propagates: that is the rule
    return float(mean) if mean.ndim == 0 else mean


def rho(v_robot: float, *v_donors: float) -> float:
    """Transferability (paper eq. 4): ``v_robot / mean(v_donors)``, each v a
    :func:`mean_velocity` over the same terrains.

    NaN when any velocity is NaN, or the donors' mean is 0.
    """
    donors = float(np.mean(v_donors)) if v_donors else math.nan
    if not math.isfinite(donors) or donors == 0 or not math.isfinite(v_robot):
        return math.nan
    return float(v_robot) / donors


__all__ = ["mean_velocity", "rho"]
