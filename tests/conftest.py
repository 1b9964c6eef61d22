"""Shared fixtures: the paper's bodies and quiet (noise-free) simulation settings."""

from __future__ import annotations

import numpy as np
import pytest

from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.system import geometry


@pytest.fixture(scope="session")
def worm() -> Body:
    return Body.build("worm")


@pytest.fixture(scope="session")
def biped() -> Body:
    return Body.build("biped")


def quiet(**options) -> SimConfig:
    """Settings without sensor noise, so that readings are exact geometry."""
    return SimConfig(noise_sigma=0.0).with_options(**options)


def voxel_geometry(body: Body, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres (V, 2) and area ratios (V,) of a body's voxels from corner positions (P, 2)."""
    quads = pos[geometry(body).corners]  # (V, 4, 2)
    x, y = quads[..., 0], quads[..., 1]
    area = 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(axis=1)
    return quads.mean(axis=1), area / 9.0
