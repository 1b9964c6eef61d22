"""A recorded episode of one robot, and the world geometry a frame draws from it.

:class:`Recording` is what the pictures of an episode (paper Figure 1 and Figure 4) are drawn
from: the corner positions, actuation, readings and contacts at every control step, and the v_x
shown on screen. :func:`area_ratio`, :func:`voxel_angles` and :func:`lidar_segments` turn one step
into world quantities [m]; :func:`moving_average` smooths the centre of mass the camera follows.

This module reads recordings only; :mod:`somite.viz.video` runs the simulation through the
public :func:`somite.tasks.locomotion.simulate_batch`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..sim.body import Body
from ..sim.config import CONTROL_HZ, VOXEL_SIDE, SimConfig
from ..sim.system import geometry
from ..sim.terrain import Terrain

VELOCITY_WINDOW = 30
"""Control steps (0.5 s) over which the on-screen v_x is averaged."""
CAMERA_WINDOW = 15
"""Half-width in control steps of the moving average the camera follows (no jitter)."""


@dataclass(frozen=True, eq=False)
class Recording:
    """One robot's recorded episode (T = recorded control steps + 1).

    Attributes
    ----------
    body, terrain, config
        What was simulated.
    corners : numpy.ndarray
        (V, 4) point indices of each voxel's corners SW, SE, NE, NW.
    pos : numpy.ndarray
        (T, P, 2) corner positions [m].
    actuation : numpy.ndarray
        (T, V) actuation in [-1, 1] (+1 contracts).
    readings : numpy.ndarray
        (T, R) normalised noisy readings, in ``body.readings`` order.
    contact : numpy.ndarray
        (T, P) bool, corners touching the ground.
    com : numpy.ndarray
        (T, 2) centre of mass [m].
    velocity : float
        The episode's v_x over [transient, end] (NaN when the episode blew up).
    complete : bool
        False when the simulation went non-finite and the recording stops before it did.
    """

    body: Body
    terrain: Terrain
    config: SimConfig
    corners: np.ndarray
    pos: np.ndarray
    actuation: np.ndarray
    readings: np.ndarray
    contact: np.ndarray
    com: np.ndarray
    velocity: float = math.nan
    complete: bool = True

    @classmethod
    def from_trace(cls, trace, robot: int, body: Body, terrain: Terrain, config: SimConfig,
                   velocity: float = math.nan) -> Recording:
        """Robot ``robot`` of a trace recorded with ``simulate_batch(..., record=True)``.

        The recording is cut before the first step with a non-finite position, if any.
        """
        if len(trace.pos) == 0:
            raise ValueError("the trace was not recorded; simulate with record=True")
        n_points = len(geometry(body).points)
        n_voxels = body.shape.n_voxels
        pos = trace.pos[robot][:, :n_points]
        finite = np.isfinite(pos).all(axis=(1, 2)) & np.isfinite(trace.com[robot]).all(axis=1)
        end = len(pos) if finite.all() else max(1, int(np.argmin(finite)))
        return cls(
            body=body,
            terrain=terrain,
            config=config,
            corners=geometry(body).corners.astype(np.int64),
            pos=pos[:end],
            actuation=trace.actuation[robot][:end, :n_voxels],
            readings=trace.readings[robot][:end, : body.n_readings],
            contact=trace.contact[robot][:end, :n_points],
            com=trace.com[robot][:end],
            velocity=float(velocity),
            complete=end == len(pos),
        )

    @property
    def n_steps(self) -> int:
        """Recorded control steps (rows minus the initial state)."""
        return len(self.pos) - 1

    def quads(self, step: int) -> np.ndarray:
        """(V, 4, 2) voxel corners SW, SE, NE, NW at ``step`` [m]."""
        return self.pos[step][self.corners]

    def area_ratio(self, step: int) -> np.ndarray:
        """(V,) each voxel's area over its rest area (shoelace formula)."""
        return area_ratio(self.quads(step))

    def velocity_at(self, step: int, window: int = VELOCITY_WINDOW) -> float:
        """v_x of the centre of mass over the last ``window`` steps [m/s] (0 at step 0)."""
        start = max(0, step - window)
        if step == start:
            return 0.0
        return float((self.com[step, 0] - self.com[start, 0]) * CONTROL_HZ / (step - start))

    @cached_property
    def camera(self) -> np.ndarray:
        """(T, 2) the point the camera follows: the centre of mass, moving-averaged."""
        return moving_average(self.com, CAMERA_WINDOW)

    @cached_property
    def sensor_groups(self) -> list[list[tuple[str, list[int]]]]:
        """Per voxel, per sensor: (kind, indices of its readings in ``readings``)."""
        groups: list[list[tuple[str, list[int]]]] = [[] for _ in self.body.shape.voxels]
        for r, reading in enumerate(self.body.readings):
            sensors = groups[reading.voxel]
            if reading.component == 0:
                sensors.append((reading.kind, []))
            sensors[-1][1].append(r)
        return groups


def area_ratio(quads: np.ndarray) -> np.ndarray:
    """(..., V) area of quadrilaterals (..., V, 4, 2) over the rest area VOXEL_SIDE**2."""
    x = quads[..., 0]
    y = quads[..., 1]
    twice = np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)
    return 0.5 * twice / VOXEL_SIDE**2


def moving_average(values: np.ndarray, half: int) -> np.ndarray:
    """Centred moving average along axis 0 over 2 * half + 1 rows, shrinking at the ends."""
    n = len(values)
    cumulative = np.concatenate([np.zeros((1,) + values.shape[1:]), np.cumsum(values, axis=0)])
    lo = np.clip(np.arange(n) - half, 0, n)
    hi = np.clip(np.arange(n) + half + 1, 0, n)
    count = (hi - lo).reshape((-1,) + (1,) * (values.ndim - 1))
    return (cumulative[hi] - cumulative[lo]) / count


def voxel_angles(quads: np.ndarray) -> np.ndarray:
    """(V,) each voxel's orientation [rad]: the mean direction of its bottom and top sides,
    as the voxel-frame sensors compute it."""
    side = quads[:, 1] - quads[:, 0] + quads[:, 2] - quads[:, 3]
    return np.arctan2(side[:, 1], side[:, 0])


def lidar_segments(recording: Recording, step: int, quads: np.ndarray | None = None):
    """World segments [m] of every lidar ray at ``step``: a list of (start (2,), end (2,)).

    A ray starts at its voxel's centre, points along config.lidar_angles (turned with the
    voxel when lidar_frame is "voxel"), and is as long as its reading times lidar_range.
    """
    quads = recording.quads(step) if quads is None else quads
    config = recording.config
    angles = np.asarray(config.lidar_angles, dtype=np.float64)
    turn = voxel_angles(quads) if config.lidar_frame == "voxel" else np.zeros(len(quads))
    segments = []
    for v, sensors in enumerate(recording.sensor_groups):
        for kind, indices in sensors:
            if kind != "lidar":
                continue
            centre = quads[v].mean(axis=0)
            length = np.clip(recording.readings[step, indices], 0.0, 1.0) * config.lidar_range
            for angle, reach in zip(angles + turn[v], length):
                end = centre + reach * np.array([math.cos(angle), math.sin(angle)])
                segments.append((centre, end))
    return segments


__all__ = [
    "Recording",
    "area_ratio",
    "lidar_segments",
    "moving_average",
    "voxel_angles",
]
