"""One robot's share of a batch, as the physics kernels take it.

The batch arrays of :class:`~somite.sim.system.System` are padded; these NamedTuples hold one
robot's views of them (trimmed to its own counts) and the terrain it runs on, so that a kernel
takes a few arguments instead of twenty; what a step changes is its
:class:`~somite.sim.state.BodyState`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._jit import njit
from .state import BodyState, contact_capacity
from .state_views import new_body


class Robot(NamedTuple):
    """Static arrays of one robot (P blocks, S springs, Y ropes, W welds, C colliding pairs,
    V voxels); offsets [m] from a block's centre, in its frame."""

    n_points: int
    n_springs: int
    n_ropes: int
    n_welds: int
    n_pairs: int
    n_voxels: int
    ends: np.ndarray  # (S, 2) int32 body indices
    anchor: np.ndarray  # (S, 4) anchor offsets on body a, then on body b
    kind: np.ndarray  # (S,) int32 SPRING_* group, which sets the range of the rest length
    owner: np.ndarray  # (S,) int32 voxel whose actuation sets the rest length
    rope_ends: np.ndarray  # (Y, 2) int32
    weld_ends: np.ndarray  # (W, 2) int32
    weld_anchor: np.ndarray  # (W, 2) the first body's centre, offset on the second
    pair_ends: np.ndarray  # (C, 2) int32
    mass: np.ndarray  # (P,) [kg]
    inv_mass: np.ndarray  # (P,) [1/kg]
    inv_inertia: np.ndarray  # (P,) [1/(kg m^2)]
    corner_offset: np.ndarray  # (P, 2) the voxel corner each block carries
    corners: np.ndarray  # (V, 4) int32 SW, SE, NE, NW


class Ground(NamedTuple):
    """The terrain of one robot: K vertices, strictly increasing in x."""

    n: int
    xs: np.ndarray  # (K,) [m]
    ys: np.ndarray  # (K,) [m]
    nx: np.ndarray  # (K,) unit normal of segment [k, k + 1], up out of the ground
    ny: np.ndarray  # (K,)


@njit
def robot_view(system, b, params) -> Robot:
    """Robot ``b`` of ``system``."""
    n_points = system.n_points[b]
    return fill_robot(system, b, params, np.empty(n_points), np.empty(n_points))


@njit
def fill_robot(system, b, params, inv_mass, inv_inertia) -> Robot:
    """:func:`robot_view` with its two derived arrays (P,) supplied and filled: a GPU thread
    cannot allocate them."""
    n_points = system.n_points[b]
    for p in range(n_points):
        inv_mass[p] = 1.0 / system.mass[b, p]
        inv_inertia[p] = 1.0 / system.inertia[b, p]
    return filled_robot(system, b, inv_mass, inv_inertia)


@njit(inline="always")
def filled_robot(system, b, inv_mass, inv_inertia) -> Robot:
    """Robot ``b`` over derived arrays that :func:`fill_robot` filled before."""
    n_points = system.n_points[b]
    n_springs = system.n_springs[b]
    n_ropes = system.n_ropes[b]
    n_welds = system.n_welds[b]
    n_pairs = system.n_pairs[b]
    return Robot(
        n_points, n_springs, n_ropes, n_welds, n_pairs, system.n_voxels[b],
        system.spring_ends[b, :n_springs], system.spring_anchor[b, :n_springs],
        system.spring_kind[b, :n_springs], system.spring_owner[b, :n_springs],
        system.rope_ends[b, :n_ropes], system.weld_ends[b, :n_welds],
        system.weld_anchor[b, :n_welds], system.pair_ends[b, :n_pairs],
        system.mass[b, :n_points], inv_mass, inv_inertia, system.corner_offset[b, :n_points],
        system.voxel_corners[b],
    )


@njit(inline="always")
def ground_view(system, b) -> Ground:
    # Inlined: kernels compiled without reference counting call it, and the views that a
    # compiled call returns counted would never be released (see episode.uncounted_work_row).
    t = system.terrain_of[b]
    return Ground(system.terrain_n[t], system.terrain_x[t], system.terrain_y[t],
                  system.terrain_nx[t], system.terrain_ny[t])


@njit
def robot_body(robot) -> BodyState:
    """A :class:`~somite.sim.state.BodyState` of its own for ``robot``, at the start of an
    episode (:func:`reset_body`) and holding the robot's inverse masses; its bodies' state is
    left to set."""
    state = new_body((robot.n_points, robot.n_springs, robot.n_ropes, robot.n_welds,
                      contact_capacity(robot.n_points, robot.n_pairs)))
    for p in range(robot.n_points):
        state.inv_mass[p] = robot.inv_mass[p]
        state.inv_inertia[p] = robot.inv_inertia[p]
    reset_body(robot, state)
    return state


@njit
def reset_body(robot, state) -> None:
    """Set ``state`` (a :class:`~somite.sim.state.BodyState`) to the start of an episode: no
    impulses, bodies unrotated, no contact (the rest lengths are set by the episode before its
    first step, the bodies' positions by its start)."""
    rest = state.rest
    spring = state.spring
    rope = state.rope
    weld = state.weld
    counts = state.counts
    cos = state.cos
    sin = state.sin
    contact = state.contact
    segment = state.segment
    for s in range(robot.n_springs):
        rest[s] = 0.0
        for j in range(spring.shape[1]):
            spring[s, j] = 0.0
    for r in range(robot.n_ropes):
        for j in range(rope.shape[1]):
            rope[r, j] = 0.0
    for q in range(robot.n_welds):
        for j in range(weld.shape[1]):
            weld[q, j] = 0.0
    counts[0] = counts[1] = 0
    for p in range(robot.n_points):
        cos[p] = 1.0
        sin[p] = 0.0
        contact[p] = False
    for f in range(robot.n_points + 1):
        segment[f] = 0
