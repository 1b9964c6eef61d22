"""somite.sim.trig.sincos, the physics' own cosine and sine: within an ulp or two of libm's,
exact where a still robot needs it, NaN where the angle is not finite."""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite._jit import njit
from somite.sim.trig import sincos


@njit
def _sincos_all(x):
    c = np.empty_like(x)
    s = np.empty_like(x)
    for i in range(x.shape[0]):
        c[i], s[i] = sincos(x[i])
    return c, s


def _ulps(ours, libm):
    return np.abs(ours - libm) / np.spacing(np.maximum(np.abs(libm), 1e-300))


@pytest.mark.parametrize(("scale", "ulps"), [(1e-3, 0), (4.0, 1), (100.0, 1), (1e5, 2)])
def test_within_ulps_of_libm(scale, ulps):
    x = np.random.default_rng(0).uniform(-scale, scale, 200_000)
    c, s = _sincos_all(x)
    assert _ulps(c, np.cos(x)).max() <= ulps
    assert _ulps(s, np.sin(x)).max() <= ulps


def test_quadrant_edges_and_specials():
    x = np.array([0.0, math.pi / 4, math.pi / 2, math.pi, -math.pi, 1.5 * math.pi, 7.0 * math.pi,
                  -100.5 * math.pi, np.nextafter(math.pi / 4, 1.0)])
    c, s = _sincos_all(x)
    assert (c[0], s[0]) == (1.0, 0.0)  # an unturned block is exactly unturned
    tolerance = 3e-16 * np.maximum(1.0, np.abs(x))
    assert (np.abs(c - np.cos(x)) <= tolerance).all()
    assert (np.abs(s - np.sin(x)) <= tolerance).all()
    c, s = _sincos_all(np.array([np.nan, np.inf, -np.inf]))
    assert np.isnan(c).all() and np.isnan(s).all()


def test_unit_length():
    x = np.random.default_rng(1).uniform(-50.0, 50.0, 100_000)
    c, s = _sincos_all(x)
    assert np.abs(c * c + s * s - 1.0).max() < 4e-16
