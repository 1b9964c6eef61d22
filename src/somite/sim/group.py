"""Groups: robots of one body that advance together, as the lanes of vector instructions.

A physics step is mostly sequential-impulse passes over a robot's joints, each joint's impulse
waiting for the one before it, so one robot's pass is a chain of dependent arithmetic. Robots
with the same body have the same joints, so a group of them (at most :data:`GROUP_SIZE`,
neighbours in a batch) runs each pass for all of them at once, robot by robot in the lanes of
:class:`~somite.sim.joint_lanes.Lanes`. :func:`groups` splits a batch into groups; a
:class:`Group` holds one group's lanes and the bookkeeping of its robots for its whole episode.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._jit import njit
from . import joint_lanes as jl
from .physics import N_ROPE_COLUMNS, N_SPRING_COLUMNS, N_WELD_COLUMNS

GROUP_SIZE = jl.LANES
"""Robots a group advances together at most."""


class Group(NamedTuple):
    """The robots ``first .. first + count - 1`` of a batch, all of one body, as they advance
    together: robot b's lane and ``flags`` row (:data:`~somite.sim.joint_lanes.DONE`, ...) are
    b - first; ``running`` holds the robots still running first. A benchmark that times the
    group's parts passes ``spent`` with a row a part (``clock`` holds the cycle counter between
    them); otherwise ``spent`` has no rows."""

    first: int
    count: int
    lanes: jl.Lanes
    running: np.ndarray  # (count,) int64
    flags: np.ndarray  # (LANES, 4) bool
    spent: np.ndarray  # (parts,) uint64 cycles, or (0,)
    clock: np.ndarray  # (1,) uint64


def body_key(system, b: int) -> bytes:
    """What robots of one group must share: their joints and their blocks' masses."""
    p, s = system.n_points[b], system.n_springs[b]
    y, q = system.n_ropes[b], system.n_welds[b]
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (
        np.array([p, s, y, q]), system.spring_ends[b, :s], system.spring_anchor[b, :s],
        system.rope_ends[b, :y], system.weld_ends[b, :q], system.weld_anchor[b, :q],
        system.mass[b, :p], system.inertia[b, :p]))


def groups(system, group_size: int = GROUP_SIZE, threads: int | None = None):
    """(first, count) arrays: consecutive robots of a batch's ``system`` with the same body
    (:func:`body_key`), at most ``group_size`` a group and small enough that every thread gets
    one."""
    n = system.n_points.shape[0]
    threads = threads or numba.get_num_threads()
    size = max(1, min(group_size, math.ceil(n / threads)))
    key = [body_key(system, b) for b in range(n)]
    first, count = [], []
    for b in range(n):
        if count and count[-1] < size and key[b] == key[first[-1]]:
            count[-1] += 1
        else:
            first.append(b)
            count.append(1)
    return np.array(first, dtype=np.int64), np.array(count, dtype=np.int64)


@njit
def new_group(system, first, count, masses, spent):
    """The :class:`Group` of robots ``first .. first + count - 1``; ``masses``: robot
    ``first``'s inverse masses and inertias (every robot of the group has them). The lanes'
    state is left to fill."""
    p, s = system.n_points[first], system.n_springs[first]
    y, q = system.n_ropes[first], system.n_welds[first]
    width = jl.LANES
    ends, rope_ends = system.spring_ends[first, :s].copy(), system.rope_ends[first, :y].copy()
    weld_ends = system.weld_ends[first, :q].copy()
    lanes = jl.Lanes(
        ends, system.spring_anchor[first, :s].copy(), rope_ends, weld_ends,
        system.weld_anchor[first, :q].copy(), masses[0].copy(), masses[1].copy(),
        np.empty((p, 3, width)), np.empty((p, 3, width)), np.empty((p, width)),
        np.empty((p, width)), np.zeros((s, width)), np.zeros((s, N_SPRING_COLUMNS, width)),
        np.zeros((y, N_ROPE_COLUMNS, width)), np.zeros((q, N_WELD_COLUMNS, width)),
        jl.exact_order(ends, p), jl.exact_order(rope_ends, p), jl.exact_order(weld_ends, p))
    return Group(first, count, lanes, np.arange(first, first + count),
                 np.empty((width, 4), dtype=np.bool_), spent, np.zeros(1, dtype=np.uint64))
