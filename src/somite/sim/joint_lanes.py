"""A group's robots as the lanes of vector instructions: their state stored robots innermost,
and the passes over it.

Every robot of a group (:mod:`somite.tasks.lanes`) has the same body, so a joint joins the same
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
           "give", "move", "solve_joints", "start_joints", "take"]


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
    start_springs(lanes.ends, lanes.anchor, lanes.rest, lanes.spring,
                  (lanes.pos, lanes.vel, lanes.cos, lanes.sin), (lanes.inv_mass, lanes.inv_inertia),
                  (params.dt, omega, params.damping_ratio))
    start_ropes(lanes.rope_ends, lanes.rope, lanes.pos, lanes.vel, lanes.inv_mass,
                lanes.inv_inertia)
    start_welds(lanes.weld_ends, lanes.weld_anchor, lanes.weld, lanes.vel, lanes.cos,
                lanes.sin, lanes.inv_mass, lanes.inv_inertia)


@njit(inline="always")
def fix_joints(lanes, flags):
    """One position pass over the rope limits, then the welds, of every busy lane."""
    fix_ropes(lanes.rope_ends, lanes.pos, lanes.inv_mass, lanes.inv_inertia, flags)
    fix_welds(lanes.weld_ends, lanes.weld_anchor, lanes.pos, lanes.cos, lanes.sin,
              lanes.inv_mass, lanes.inv_inertia, flags)


@njit(inline="always")
def solve_joints(lanes):
    """One velocity pass over the joints of every lane: springs, rope limits, welds."""
    solve_springs(lanes.ends, lanes.spring, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
    solve_ropes(lanes.rope_ends, lanes.rope, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
    solve_welds(lanes.weld_ends, lanes.weld, lanes.vel, lanes.inv_mass, lanes.inv_inertia)
