"""Sensor readings of one robot, computed once per control step (docs/decisions.md, "Sensors").

Each kind of sensor is a row of :data:`~somite.sim.sensor_kinds.SENSORS` and a branch of
:func:`sense`; a sensor that keeps a history (touch, velocity) also has its ring buffer in
:class:`Sensing`, filled by :func:`update_histories`.

Readings are normalised to about [0, 1]: area ratio and velocity through the soft
normalisation 0.5 + 0.5 tanh(2(2v - 1)) of their domain ([0.5, 1.5] and [-v_max, v_max]), touch
as 0/1 (or its moving average), lidar as distance / range (1 when the ray hits nothing); touch
and lidar are not soft-normalised, as in the authors' code. Gaussian noise of standard deviation
``noise_sigma`` is added last, unclipped.

With ``noise_stream = "independent"`` the noise comes from a counter-based generator keyed by
(robot seed, step, reading): it needs no state, so a robot's noise does not depend on its thread
or on the other robots of its batch. With ``"java-random-0"`` it is read from one precomputed
table of ``java.util.Random(0)`` Gaussians (:func:`noise_table`), the same for every robot.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit, uncounted
from .._math import tanh
from .config import IN_VOXEL_FRAME, MEAN_OF_ANGLES, SimConfig
from .java_random import JavaRandom
from .physics import segment_near, voxel_corners
from .sensor_kinds import (
    AREA,
    LIDAR,
    NOISE_STRIDE,
    READING_COMPONENT,
    READING_KIND,
    TOUCH,
    VELOCITY,
)

AREA_LOW, AREA_HIGH = 0.5, 1.5
VOXEL_AREA = 9.0
NO_ANGLE, VECTOR_MEAN, ANGLE_MEAN = 0, 1, 2
"""What :func:`voxel_state` computes as the voxel angle (see :func:`angle_mode`)."""
NOISE_PER_STEP = int(NOISE_STRIDE.max())
"""Gaussians of the authors' noise stream that the most spending sensor (the lidar) uses per
control step: :func:`noise_table` holds that many a step."""


class Sensing(NamedTuple):
    """One robot's sensors, as :func:`sense` and :func:`update_histories` read them: views of
    its batch's arrays (R readings, V voxels)."""

    n_readings: int
    code: np.ndarray  # (R,) int32 each reading's code (sensor_kinds.reading_code)
    voxel: np.ndarray  # (R,) int32 the voxel it reads
    voxels: np.ndarray  # (V, 6) voxel_state's
    touch_hist: np.ndarray  # (V, touch_window) contacts of the last steps (a ring buffer)
    vel_hist: np.ndarray  # (V, velocity_window, 2) velocities of the last steps (a ring buffer)
    rays: np.ndarray  # (5, 2) lidar_rays(params)


_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_STEP_KEY = np.uint64(0xD6E8FEB86659FD93)
_S30, _S27, _S31, _S32 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(32)
_LOW32 = np.uint64(0xFFFFFFFF)


@njit
def _mix(z):
    """splitmix64's finaliser: a bijective scramble of a 64-bit integer."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@njit
def gaussian_pair(seed, step, pair):
    """Two independent standard normal draws that depend only on (seed, step, pair).

    Marsaglia's polar method on counter-based uniforms: no trigonometry, and each retry
    hashes the next counter value, so the result stays a pure function of its key.
    """
    key = _mix(np.uint64(seed) + np.uint64(step) * _STEP_KEY + np.uint64(pair) * _GOLDEN)
    while True:
        key = _mix(key + _GOLDEN)
        u = float(key >> _S32) * 2.0**-31 - 1.0
        v = float(key & _LOW32) * 2.0**-31 - 1.0
        s = u * u + v * v
        if 0.0 < s < 1.0:
            factor = math.sqrt(-2.0 * math.log(s) / s)
            return u * factor, v * factor


def noise_table(config: SimConfig) -> np.ndarray:
    """The Gaussians the kernel reads under ``noise_stream = "java-random-0"``, else none.

    Each of the authors' sensors owns a ``java.util.Random(0)``, restarted each episode, and
    draws one Gaussian per value per step: a 1-D sensor gets #k at step k (from 1), the 2-D
    velocity #2k-1 and #2k, the lidar #5k-4..#5k (docs/original-system.md section 2.1). Entry
    ``stride * (k - 1) + j`` of this table is Gaussian #``stride * (k - 1) + j + 1``
    (``stride``: the kind's :attr:`~somite.sim.sensor_kinds.SensorKind.noise_stride`).
    """
    if config.noise_stream != "java-random-0":
        return np.zeros(0)
    rng = JavaRandom(0)
    return np.array([rng.next_gaussian() for _ in range(NOISE_PER_STEP * config.n_steps)])


@njit
def angle_mode(params) -> int:
    """The voxel angle :func:`voxel_state` must compute: none unless a sensor reads in the
    voxel frame, else the configured ``voxel_angle``."""
    if params.lidar_frame != IN_VOXEL_FRAME and params.velocity_frame != IN_VOXEL_FRAME:
        return NO_ANGLE
    return ANGLE_MEAN if params.voxel_angle == MEAN_OF_ANGLES else VECTOR_MEAN


@njit
def soft_normalise(x, low, high) -> float:
    v = (x - low) / (high - low)
    return 0.5 + 0.5 * tanh(2.0 * (2.0 * v - 1.0))


@uncounted
def voxel_state(n_voxels, corners, pos, vel, angle, out):
    """Per voxel: centre x, y, velocity x, y, area ratio, angle -> ``out`` (V, 6).

    The angle, only needed by voxel-frame sensors, is 0 with ``angle = NO_ANGLE``; with
    ``VECTOR_MEAN`` the direction of the bottom side plus the top side (west to east); with
    ``ANGLE_MEAN`` the mean of the two sides' directions, as the authors' code computes it.
    """
    for v in range(n_voxels):
        cx = 0.0
        cy = 0.0
        vx = 0.0
        vy = 0.0
        area = 0.0
        for k in range(4):
            p = corners[v, k]
            q = corners[v, (k + 1) % 4]
            cx += pos[p, 0]
            cy += pos[p, 1]
            vx += vel[p, 0]
            vy += vel[p, 1]
            area += pos[p, 0] * pos[q, 1] - pos[q, 0] * pos[p, 1]
        out[v, 5] = 0.0
        if angle != NO_ANGLE:
            sw, se, ne, nw = voxel_corners(corners, v)
            bx = pos[se, 0] - pos[sw, 0]
            by = pos[se, 1] - pos[sw, 1]
            tx = pos[ne, 0] - pos[nw, 0]
            ty = pos[ne, 1] - pos[nw, 1]
            if angle == VECTOR_MEAN:
                out[v, 5] = math.atan2(by + ty, bx + tx)
            else:
                # A plain mean of two angles: wrong by pi when they straddle +-pi (kept on
                # purpose, it is the authors' sensor frame).
                out[v, 5] = 0.5 * (math.atan2(ty, tx) + math.atan2(by, bx))
        out[v, 0] = 0.25 * cx
        out[v, 1] = 0.25 * cy
        out[v, 2] = 0.25 * vx
        out[v, 3] = 0.25 * vy
        out[v, 4] = 0.5 * area / VOXEL_AREA


@uncounted
def raycast(x0, y0, dx, dy, reach, ground, guess) -> float:
    """Distance along the unit ray (dx, dy) from (x0, y0) to the terrain ``ground``, or
    ``reach``.

    ``guess`` is a segment index near the ray's start (the search walks from it)."""
    xs, ys, n = ground.xs, ground.ys, ground.n
    x1 = x0 + dx * reach
    first = segment_near(xs, n, min(x0, x1), guess)
    last_x = max(x0, x1)
    best = reach
    for j in range(first, n - 1):
        if xs[j] > last_x:
            break
        sx = xs[j + 1] - xs[j]
        sy = ys[j + 1] - ys[j]
        denom = dx * sy - dy * sx
        if denom == 0.0:
            continue
        rx = xs[j] - x0
        ry = ys[j] - y0
        t = (rx * sy - ry * sx) / denom
        u = (rx * dy - ry * dx) / denom
        if 0.0 <= t < best and 0.0 <= u <= 1.0:
            best = t
    return best


@uncounted
def update_histories(step, n_voxels, corners, contact, sensing, params):
    """Store this step's touch (``contact``: (P,) per block) and velocity (in the configured
    frame) in ``sensing``'s ring buffers."""
    voxels = sensing.voxels
    touch_hist = sensing.touch_hist
    vel_hist = sensing.vel_hist
    wt = int(params.touch_window)
    wv = int(params.velocity_window)
    rotate = params.velocity_frame == IN_VOXEL_FRAME
    for v in range(n_voxels):
        touching = 0.0
        for k in range(4):
            if contact[corners[v, k]]:
                touching = 1.0
        touch_hist[v, step % wt] = touching
        vx = voxels[v, 2]
        vy = voxels[v, 3]
        if rotate:
            c = math.cos(voxels[v, 5])
            s = math.sin(voxels[v, 5])
            vx, vy = vx * c + vy * s, -vx * s + vy * c
        vel_hist[v, step % wv, 0] = vx
        vel_hist[v, step % wv, 1] = vy


@uncounted
def _window_mean(hist, v, step, slot, window, column) -> float:
    """The mean of ``hist``'s last min(step + 1, window) rows from ``slot`` (step % window)
    back, newest first."""
    count = min(step + 1, window)
    total = 0.0
    for _ in range(count):
        total += hist[v, slot, column]
        slot = slot - 1 if slot > 0 else window - 1
    return total / count


@uncounted
def sense(step, seed, sensing, ground, guess, params, noise, readings):
    """Fill ``readings`` (R,) for control step ``step`` (from 0; histories already updated);
    ``ground`` is the robot's terrain (``n``, ``xs``, ``ys``), ``guess`` a segment of it near
    the robot; ``noise`` is :func:`noise_table`'s (empty: independent noise from ``seed``)."""
    n_readings = sensing.n_readings
    codes = sensing.code
    reading_voxel = sensing.voxel
    voxels = sensing.voxels
    touch_hist = sensing.touch_hist
    vel_hist = sensing.vel_hist
    rays = sensing.rays
    wt = int(params.touch_window)
    wv = int(params.velocity_window)
    vmax = params.velocity_max
    reach = params.lidar_range
    sigma = params.noise
    # The ring buffers' rows of this step, once: a division each, not one a reading.
    touch_slot = step % wt
    velocity_slot = step % wv
    for r in range(n_readings):
        v = reading_voxel[r]
        kind = READING_KIND[codes[r]]
        component = READING_COMPONENT[codes[r]]
        value = 0.0
        if kind == AREA:
            value = soft_normalise(voxels[v, 4], AREA_LOW, AREA_HIGH)
        elif kind == TOUCH:
            count = min(step + 1, wt)
            total = 0.0
            slot = touch_slot
            for _ in range(count):
                total += touch_hist[v, slot]
                slot = slot - 1 if slot > 0 else wt - 1
            value = total / count
        elif kind == VELOCITY:
            mean = _window_mean(vel_hist, v, step, velocity_slot, wv, component)
            value = soft_normalise(mean, -vmax, vmax)
        elif kind == LIDAR:
            dx = rays[component, 0]
            dy = rays[component, 1]
            if params.lidar_frame == IN_VOXEL_FRAME:
                c = math.cos(voxels[v, 5])
                s = math.sin(voxels[v, 5])
                dx, dy = dx * c - dy * s, dx * s + dy * c
            hit = raycast(voxels[v, 0], voxels[v, 1], dx, dy, reach, ground, guess)
            value = hit / reach
        readings[r] = value
    if sigma > 0.0 and noise.shape[0] > 0:
        for r in range(n_readings):
            code = codes[r]
            index = NOISE_STRIDE[READING_KIND[code]] * step + READING_COMPONENT[code]
            readings[r] += sigma * noise[index]
    elif sigma > 0.0:
        for pair in range((n_readings + 1) // 2):
            z0, z1 = gaussian_pair(seed, step, pair)
            readings[2 * pair] += sigma * z0
            if 2 * pair + 1 < n_readings:
                readings[2 * pair + 1] += sigma * z1


@njit
def lidar_rays(params):
    """Unit direction (world frame, or voxel frame before rotation) of the 5 lidar rays."""
    rays = np.empty((5, 2))
    for k in range(5):
        rays[k, 0] = math.cos(params.lidar_angles[k])
        rays[k, 1] = math.sin(params.lidar_angles[k])
    return rays
