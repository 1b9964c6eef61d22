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
    """Static arrays of one robot (P corner bodies, S springs, Y ropes, V voxels, F outline
    vertices, Q outline blocks); offsets [m] from a body's centre of mass, in its frame."""

    n_points: int
    n_springs: int
    n_ropes: int
    n_voxels: int
    n_tips: int
    n_blocks: int
    ends: np.ndarray  # (S, 2) int32 body indices
    anchor: np.ndarray  # (S, 4) anchor offsets on body a, then on body b
    kind: np.ndarray  # (S,) int32 SPRING_* group, which sets the range of the rest length
    owner: np.ndarray  # (S,) int32 voxel whose actuation sets the rest length
    spring_mass: np.ndarray  # (S,) [kg] effective mass: stiffness and damping scale with it
    rope_ends: np.ndarray  # (Y, 2) int32
    rope_anchor: np.ndarray  # (Y, 4)
    mass: np.ndarray  # (P,) [kg]
    inv_mass: np.ndarray  # (P,) [1/kg]
    inv_inertia: np.ndarray  # (P,) [1/(kg m^2)]
    corner_offset: np.ndarray  # (P, 2) the lattice point each body carries
    corners: np.ndarray  # (V, 4) int32 SW, SE, NE, NW
    tip_body: np.ndarray  # (F,) int32
    tip_offset: np.ndarray  # (F, 2)
    block_body: np.ndarray  # (Q,) int32
    block_offset: np.ndarray  # (Q, 2)
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
    force: np.ndarray  # (P, 3) [N, N, N m] force and torque on each body, zero between
    # substeps
    cos: np.ndarray  # (P,) of each body's angle, for the current substep
    sin: np.ndarray  # (P,)
    rax: np.ndarray  # (S,) springs: anchors in the world frame, extensions, relative
    ray: np.ndarray  # velocities, forces and torques (physics.integrate)
    rbx: np.ndarray
    rby: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    dvx: np.ndarray
    dvy: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    ta: np.ndarray
    tb: np.ndarray
    dpos: np.ndarray  # (P, 3) contact corrections found in a substep, zero between substeps
    dvel: np.ndarray  # (P, 3)
    hits: np.ndarray  # (P, 2) contacts found per body, approaching ones; zero between substeps
    contact: np.ndarray  # (P,) bool: the body touches the ground
    segment: np.ndarray  # (F + 1,) int64 terrain segment under each outline vertex, then
    # under the robot's left end


@njit
def robot_view(system, b, params) -> Robot:
    """Robot ``b`` of ``system`` with the limits of ``params``."""
    n_points = system.n_points[b]
    return robot_in(system, b, params, np.empty(n_points), np.empty(n_points))


@njit
def robot_in(system, b, params, inv_mass, inv_inertia) -> Robot:
    """:func:`robot_view` with its two derived arrays (P,) supplied and filled: a GPU thread
    cannot allocate them."""
    n_points = system.n_points[b]
    n_springs = system.n_springs[b]
    n_ropes = system.n_ropes[b]
    n_tips = system.n_tips[b]
    n_blocks = system.n_blocks[b]
    mass = system.mass[b, :n_points]
    for p in range(n_points):
        inv_mass[p] = 1.0 / mass[p]
        inv_inertia[p] = 1.0 / system.inertia[b, p]
    return Robot(
        n_points, n_springs, n_ropes, system.n_voxels[b], n_tips, n_blocks,
        system.spring_ends[b, :n_springs], system.spring_anchor[b, :n_springs],
        system.spring_kind[b, :n_springs], system.spring_owner[b, :n_springs],
        system.spring_mass[b, :n_springs], system.rope_ends[b, :n_ropes],
        system.rope_anchor[b, :n_ropes], mass, inv_mass, inv_inertia,
        system.corner_offset[b, :n_points], system.voxel_corners[b],
        system.tip_body[b, :n_tips], system.tip_offset[b, :n_tips],
        system.block_body[b, :n_blocks], system.block_offset[b, :n_blocks],
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
        robot, np.empty(s), np.empty((robot.n_points, 3)),
        np.empty(robot.n_points), np.empty(robot.n_points), np.empty(s), np.empty(s),
        np.empty(s), np.empty(s), np.empty(s), np.empty(s), np.empty(s), np.empty(s),
        np.empty(s), np.empty(s), np.empty(s), np.empty(s), np.empty((robot.n_points, 3)),
        np.empty((robot.n_points, 3)), np.empty((robot.n_points, 2)),
        np.empty(robot.n_points, dtype=np.bool_), np.empty(robot.n_tips + 1, dtype=np.int64),
    )


@njit
def scratch_in(robot, rest, force, cos, sin, rax, ray, rbx, rby, dx, dy, dvx, dvy, fx, fy, ta,
               tb, dpos, dvel, hits, contact, segment) -> Scratch:
    """A :class:`Scratch` over supplied arrays (sizes as its fields'), set to the start of an
    episode: forces zero, bodies unrotated, no contact. The rest lengths are set by the
    episode before its first substep."""
    for s in range(robot.n_springs):
        rest[s] = rax[s] = ray[s] = rbx[s] = rby[s] = dx[s] = dy[s] = 0.0
        dvx[s] = dvy[s] = fx[s] = fy[s] = ta[s] = tb[s] = 0.0
    for p in range(robot.n_points):
        for j in range(3):
            force[p, j] = dpos[p, j] = dvel[p, j] = 0.0
        hits[p, 0] = hits[p, 1] = 0.0
        cos[p] = 1.0
        sin[p] = 0.0
        contact[p] = False
    for f in range(robot.n_tips + 1):
        segment[f] = 0
    return Scratch(rest, force, cos, sin, rax, ray, rbx, rby, dx, dy, dvx, dvy, fx, fy, ta, tb,
                   dpos, dvel, hits, contact, segment)
