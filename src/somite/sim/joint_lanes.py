"""A group's robots as the lanes of vector instructions: their state stored robots innermost,
and the passes over it.

Every robot of a group (:mod:`somite.sim.group`) has the same body, so a joint joins the same
two blocks in each, and only the state differs. Here the state is stored robots innermost:
``pos`` and ``vel`` (P, 3, LANES), ``cos`` and ``sin`` (P, LANES), a joint's work row (columns,
LANES); one joint's values of the LANES robots are adjacent in memory. The passes over it (the
joints' set-up, velocity and position passes, the move) are :mod:`somite.sim.lane_passes`,
written out lane by lane from :mod:`somite.sim.lane_templates`; each robot's numbers are
exactly those of the one-robot passes of :mod:`somite.sim.physics`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit
from .lane_passes import (
    CONTACTS_HELD,
    DONE,
    LANES,
    ROPES_HELD,
    WELDS_HELD,
    fix_ropes,
    fix_welds,
    move,
    solve_ropes,
    solve_springs,
    solve_welds,
    start_ropes,
    start_springs,
    start_welds,
)

__all__ = ["CONTACTS_HELD", "DONE", "LANES", "ROPES_HELD", "WELDS_HELD", "Lanes", "fix_joints",
           "exact_order", "give", "move", "solve_joints", "start_joints", "take"]


class Lanes(NamedTuple):
    """A group's joints (its first robot's: every robot of a group has the same body) and
    its robots' state, robots innermost (lane g: the group's robot g)."""

    ends: np.ndarray  # (S, 2) int32
    anchor: np.ndarray  # (S, 4)
    rope_ends: np.ndarray  # (Y, 2) int32
    weld_ends: np.ndarray  # (W, 2) int32
    weld_anchor: np.ndarray  # (W, 2)
    inv_mass: np.ndarray  # (P,)
    inv_inertia: np.ndarray  # (P,)
    pos: np.ndarray  # (P, 3, LANES)
    vel: np.ndarray  # (P, 3, LANES)
    cos: np.ndarray  # (P, LANES)
    sin: np.ndarray  # (P, LANES)
    rest: np.ndarray  # (S, LANES)
    spring: np.ndarray  # (S, N_SPRING_COLUMNS, LANES)
    rope: np.ndarray  # (Y, N_ROPE_COLUMNS, LANES)
    weld: np.ndarray  # (W, N_WELD_COLUMNS, LANES)
    spring_order: np.ndarray  # (S,) the order the passes take the springs in (exact_order)
    rope_order: np.ndarray  # (Y,)
    weld_order: np.ndarray  # (W,)


@njit
def exact_order(ends, n_points):
    """An order of the joints ``ends`` (J, 2) whose passes give the same numbers as theirs in
    index order, bit for bit, with joints on other blocks side by side.

    A joint's update reads and writes only its two blocks (and its own row), so a pass over
    them is fixed by the order in which each block sees its joints, and any order that keeps
    that is the same arithmetic. Joint m's level is one more than the level of the last joint
    before it on either of its blocks; sorted stably by level, the joints keep every block's
    order, and neighbours in the order share no block: their chains of dependent arithmetic
    overlap in the CPU (a voxel's springs join only its own four blocks: the worm's 216 springs
    fall in 17 levels of 12, one of 24; the springs' velocity pass took 1.41-1.49 ns a spring
    and lane instead of 1.55-1.72 on AMD Zen 5, ``audits/spring_order.py``, BENCHMARKS.md)."""
    n = ends.shape[0]
    last = np.zeros(n_points, dtype=np.int64)
    level = np.empty(n, dtype=np.int64)
    top = 0
    for m in range(n):
        a, b = ends[m, 0], ends[m, 1]
        level[m] = max(last[a], last[b]) + 1
        last[a] = level[m]
        last[b] = level[m]
        top = max(top, level[m])
    # Level by level, each in index order (a stable sort; np.argsort's took seconds to compile).
    order = np.empty(n, dtype=np.int64)
    k = 0
    for step in range(1, top + 1):
        for m in range(n):
            if level[m] == step:
                order[k] = m
                k += 1
    return order


@njit(inline="always")
def take(lanes, g, pos, vel, cos, sin):
    """Robot g's bodies (its ``pos``, ``vel`` (P, 3), ``cos``, ``sin``) into lane g."""
    for p in range(lanes.pos.shape[0]):
        for c in range(3):
            lanes.pos[p, c, g] = pos[p, c]
            lanes.vel[p, c, g] = vel[p, c]
        lanes.cos[p, g] = cos[p]
        lanes.sin[p, g] = sin[p]


@njit(inline="always")
def give(lanes, g, pos, vel, cos, sin):
    """Lane g's bodies back to robot g's ``pos``, ``vel`` (P, 3), ``cos``, ``sin``."""
    for p in range(lanes.pos.shape[0]):
        for c in range(3):
            pos[p, c] = lanes.pos[p, c, g]
            vel[p, c] = lanes.vel[p, c, g]
        cos[p] = lanes.cos[p, g]
        sin[p] = lanes.sin[p, g]


@njit(inline="always")
def start_joints(lanes, params):
    """The joints of every lane set up for this step and warm-started."""
    omega = 2.0 * math.pi * params.spring_hz
    start_springs((lanes.ends, lanes.spring_order), lanes.anchor, lanes.rest, lanes.spring,
                  (lanes.pos, lanes.vel, lanes.cos, lanes.sin), (lanes.inv_mass, lanes.inv_inertia),
                  (params.dt, omega, params.damping_ratio))
    start_ropes((lanes.rope_ends, lanes.rope_order), lanes.rope, lanes.pos, lanes.vel,
                lanes.inv_mass, lanes.inv_inertia)
    start_welds((lanes.weld_ends, lanes.weld_order), lanes.weld_anchor, lanes.weld, lanes.vel,
                lanes.cos, lanes.sin, lanes.inv_mass, lanes.inv_inertia)


@njit(inline="always")
def fix_joints(lanes, flags):
    """One position pass over the rope limits, then the welds, of every busy lane."""
    fix_ropes((lanes.rope_ends, lanes.rope_order), lanes.pos, lanes.inv_mass,
              lanes.inv_inertia, flags)
    fix_welds((lanes.weld_ends, lanes.weld_order), lanes.weld_anchor, lanes.pos, lanes.cos,
              lanes.sin, lanes.inv_mass, lanes.inv_inertia, flags)


@njit(inline="always")
def solve_joints(lanes):
    """One velocity pass over the joints of every lane: springs, rope limits, welds."""
    solve_springs((lanes.ends, lanes.spring_order), lanes.spring, lanes.vel, lanes.inv_mass,
                  lanes.inv_inertia)
    solve_ropes((lanes.rope_ends, lanes.rope_order), lanes.rope, lanes.vel, lanes.inv_mass,
                lanes.inv_inertia)
    solve_welds((lanes.weld_ends, lanes.weld_order), lanes.weld, lanes.vel, lanes.inv_mass,
                lanes.inv_inertia)
