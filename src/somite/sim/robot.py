"""One robot's share of a batch, as the physics kernels take it.

The batch arrays of :class:`~somite.sim.system.System` are padded; these NamedTuples hold one
robot's views of them (trimmed to its own counts), the terrain it runs on, and the scratch
arrays of its episode, so that a kernel takes three arguments instead of twenty.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._jit import njit
from .config import VOXEL_SIDE


class Robot(NamedTuple):
    """Static arrays of one robot (P points, S springs, V voxels, Q outer sides)."""

    n_points: int
    n_springs: int
    n_voxels: int
    n_boundary: int
    ends: np.ndarray  # (S, 2) int32 point indices
    owners: np.ndarray  # (S, 2) int32 voxel indices, -1 when one owner
    strength: np.ndarray  # (S,) stiffness factor: owners of a side (parallel springs add
    # up), ``diagonal_stiffness`` of a diagonal
    rest0: np.ndarray  # (S,) [m] rest lengths at zero actuation
    min_length: np.ndarray  # (S,) [m] hard lower limits
    mass: np.ndarray  # (P,) [kg]
    inv_mass: np.ndarray  # (P,) [1/kg]
    corners: np.ndarray  # (V, 4) int32 SW, SE, NE, NW
    boundary: np.ndarray  # (Q, 2) int32 outer sides, robot on the left of a -> b
    min_area: float  # [m^2] smallest signed area of a voxel


class Ground(NamedTuple):
    """The terrain of one robot: K vertices, strictly increasing in x."""

    n: int
    xs: np.ndarray  # (K,) [m]
    ys: np.ndarray  # (K,) [m]
    nx: np.ndarray  # (K,) unit normal of segment [k, k + 1], up out of the ground
    ny: np.ndarray  # (K,)


class Scratch(NamedTuple):
    """Working arrays of one robot's episode."""

    rest: np.ndarray  # (S,) [m] rest lengths under the current actuation
    factor: np.ndarray  # (V,) rest-length scale of each voxel
    force: np.ndarray  # (P, 2) [N], zero between substeps
    dx: np.ndarray  # (S,) spring vectors, relative velocities and forces
    dy: np.ndarray
    dvx: np.ndarray
    dvy: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    contact: np.ndarray  # (P,) bool: the point touches the ground
    segment: np.ndarray  # (P + 1,) int64 terrain segment under each point, then the leftmost


@njit
def robot_view(system, b, params) -> Robot:
    """Robot ``b`` of ``system`` with the limits of ``params``."""
    n_springs = system.n_springs[b]
    return robot_in(system, b, params, np.ones(n_springs), np.empty(n_springs),
                    np.empty(system.n_points[b]))


@njit
def robot_in(system, b, params, strength, min_length, inv_mass) -> Robot:
    """:func:`robot_view` with its three derived arrays (S,), (S,), (P,) supplied and filled:
    a GPU thread cannot allocate them."""
    n_points = system.n_points[b]
    n_springs = system.n_springs[b]
    rest0 = system.spring_rest[b, :n_springs]
    owners = system.spring_owners[b, :n_springs]
    for s in range(n_springs):
        if system.spring_diagonal[b, s]:
            strength[s] = params.diagonal
            min_length[s] = rest0[s] * params.min_diagonal
        else:
            strength[s] = 1.0 if owners[s, 1] < 0 else 2.0
            min_length[s] = rest0[s] * params.min_side
    mass = system.mass[b, :n_points]
    for p in range(n_points):
        inv_mass[p] = 1.0 / mass[p]
    return Robot(
        n_points, n_springs, system.n_voxels[b], system.n_boundary[b],
        system.spring_ends[b, :n_springs], owners, strength, rest0, min_length, mass, inv_mass,
        system.voxel_corners[b], system.boundary[b],
        params.min_area * VOXEL_SIDE * VOXEL_SIDE,
    )


@njit
def ground_view(system, b) -> Ground:
    t = system.terrain_of[b]
    return Ground(system.terrain_n[t], system.terrain_x[t], system.terrain_y[t],
                  system.terrain_nx[t], system.terrain_ny[t])


@njit
def new_scratch(robot) -> Scratch:
    s = robot.n_springs
    return scratch_in(
        robot, np.empty(s), np.empty(robot.n_voxels), np.empty((robot.n_points, 2)),
        np.empty(s), np.empty(s), np.empty(s), np.empty(s), np.empty(s), np.empty(s),
        np.empty(robot.n_points, dtype=np.bool_), np.empty(robot.n_points + 1, dtype=np.int64),
    )


@njit
def scratch_in(robot, rest, factor, force, dx, dy, dvx, dvy, fx, fy, contact,
               segment) -> Scratch:
    """A :class:`Scratch` over supplied arrays (sizes as its fields'), set to the start of an
    episode: rest lengths at zero actuation, everything else zero."""
    for s in range(robot.n_springs):
        rest[s] = robot.rest0[s]
        dx[s] = dy[s] = dvx[s] = dvy[s] = fx[s] = fy[s] = 0.0
    for v in range(robot.n_voxels):
        factor[v] = 1.0
    for p in range(robot.n_points):
        force[p, 0] = force[p, 1] = 0.0
        contact[p] = False
        segment[p] = 0
    segment[robot.n_points] = 0
    return Scratch(rest, factor, force, dx, dy, dvx, dvy, fx, fy, contact, segment)
