"""Groups: robots of one body that advance together, as the lanes of vector instructions.

A physics step is mostly sequential-impulse passes over a robot's joints, each joint's impulse
waiting for the one before it, so one robot's pass is a chain of dependent arithmetic. Robots
with the same body have the same joints, so a group of them (at most :data:`GROUP_SIZE`,
neighbours in a batch) runs each pass for all of them at once, robot by robot in the lanes of
:class:`~somite.sim.joint_lanes.Lanes`. :func:`groups` splits a batch into groups; a
:class:`Group` holds one group's lanes and the bookkeeping of its robots for its whole episode.

A group's physics step is :func:`somite.sim.step.step`, the order every backend runs, over an
:class:`InLanes` solver: the joints' set-up, velocity and position passes and the move for all
the group's robots at once (:mod:`somite.sim.joint_lanes`), each robot's arithmetic exactly its
own; the contacts' passes and their search robot by robot on their lanes. Each robot's
:class:`~somite.sim.state.BodyState` is its row of a batch's (``bodies``, robot axis first), so
an outcome is bit for bit what :func:`somite.sim.physics.advance` gives the robot alone. A
benchmark may ask a group to time its own parts (:data:`PARTS`, ``benchmarks/passes.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._cycles import cycles, tick
from .._jit import njit, uncounted
from . import joint_lanes as jl
from . import physics as ph
from . import step as order
from .physics import N_ROPE_COLUMNS, N_SPRING_COLUMNS, N_WELD_COLUMNS
from .robot import filled_robot, ground_view
from .state import body_sizes
from .state_views import body_row
from .step import implements
from .step import step as physics_step

GROUP_SIZE = jl.LANES
"""Robots a group advances together at most."""

PARTS = ("gravity, damping, contacts' set-up, into the lanes", "joints: set-up",
         "joints: velocity passes", "contacts: velocity passes", "move and rotations",
         "position passes (contacts, ropes, welds)", "out of the lanes, contacts found",
         "rest lengths", "sensing, controller, diagnostics")
"""The parts of a control step that a timed group (``spent`` with rows) counts cycles of: the
physics' (:class:`InLanes`), then the task layer's last two (``somite.tasks.lanes``)."""
(P_START, P_JOINTS_START, P_JOINTS, P_CONTACTS, P_MOVE, P_POSITIONS, P_FOUND, P_REST,
 P_SENSE) = range(len(PARTS))
NOT_TIMED = np.zeros(0, dtype=np.uint64)
"""``spent`` of a group run that is not being timed."""


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


@njit
def start_group(system, bodies, first, count, spent):
    """The :class:`Group` of robots ``first .. first + count - 1`` of a batch whose
    :class:`~somite.sim.state.BodyState` rows are ``bodies``, every lane holding robot
    ``first``'s state (a lane no robot uses keeps computing on it, harmlessly)."""
    group = new_group(system, first, count, (bodies.inv_mass[first], bodies.inv_inertia[first]),
                      spent)
    for g in range(jl.LANES):
        jl.take(group.lanes, g, bodies.body_pos[first], bodies.body_vel[first],
                bodies.cos[first], bodies.sin[first])
    return group


@njit(inline="always")
def lane(system, bodies, b):
    """Robot ``b``'s build, terrain and :class:`~somite.sim.state.BodyState` (views of
    ``bodies``). Inlined: the views are its caller's own, which a kernel compiled without
    reference counting (``advance_group``) then counts no more than its others."""
    body = body_row(bodies, b, body_sizes(system, b))
    return filled_robot(system, b, body.inv_mass, body.inv_inertia), ground_view(system, b), body


class InLanes(NamedTuple):
    """The robots ``group.running[:n]`` of a batch's group as a solver of
    :func:`somite.sim.step.step`: the joints' passes and the move in the group's lanes, the
    contacts' passes robot by robot on their lanes; each phase adds its cycles to
    ``group.spent`` when that has rows (:data:`PARTS`)."""

    system: object  # somite.sim.system.System
    bodies: object  # somite.sim.state.BodyState, robot axis first
    group: Group
    n: int


@njit(inline="always")
def _timed(solver):
    return solver.group.spent.shape[0] > 0


@njit(inline="always")
def _tick(solver, part):
    solver.group.clock[0] = tick(solver.group.spent, part, solver.group.clock[0], _timed(solver))


@implements(order.begin, InLanes)
@njit(inline="always")
def _begin(solver, params):
    if _timed(solver):
        solver.group.clock[0] = cycles()
    for i in range(solver.n):
        b = solver.group.running[i]
        robot, _, body = lane(solver.system, solver.bodies, b)
        ph.velocities(robot, body.body_vel, params)
        ph.start_contacts(robot, body, body.body_pos, body.body_vel, params)
        jl.take(solver.group.lanes, b - solver.group.first, body.body_pos, body.body_vel,
                body.cos, body.sin)
    _tick(solver, P_START)


@implements(order.start_joints, InLanes)
@njit(inline="always")
def _start_joints(solver, params):
    jl.start_joints(solver.group.lanes, params)
    _tick(solver, P_JOINTS_START)


@implements(order.solve_joints, InLanes)
@njit(inline="always")
def _solve_joints(solver, params):
    jl.solve_joints(solver.group.lanes)
    _tick(solver, P_JOINTS)


@implements(order.solve_contacts, InLanes)
@njit(inline="always")
def _solve_contacts(solver, params):
    for i in range(solver.n):
        b = solver.group.running[i]
        robot, _, body = lane(solver.system, solver.bodies, b)
        ph.solve_contacts(robot, body, solver.group.lanes.vel[:, :, b - solver.group.first])
    _tick(solver, P_CONTACTS)


@implements(order.move, InLanes)
@njit(inline="always")
def _move(solver, params):
    lanes, flags = solver.group.lanes, solver.group.flags
    jl.move(lanes.pos, lanes.vel, lanes.cos, lanes.sin, params.dt)
    # The position passes go on in a running robot's lane until its contacts and joints hold.
    for g in range(flags.shape[0]):
        flags[g, jl.DONE] = True
    for i in range(solver.n):
        flags[solver.group.running[i] - solver.group.first, jl.DONE] = False
    _tick(solver, P_MOVE)


@implements(order.fix_positions, InLanes)
@njit(inline="always")
def _fix_positions(solver, params):
    group = solver.group
    lanes, flags = group.lanes, group.flags
    for i in range(solver.n):
        g = group.running[i] - group.first
        if not flags[g, jl.DONE]:
            robot, _, body = lane(solver.system, solver.bodies, group.running[i])
            flags[g, jl.CONTACTS_HELD] = ph.fix_contacts(
                robot, body, lanes.pos[:, :, g], lanes.cos[:, g], lanes.sin[:, g])
    jl.fix_joints(lanes, flags)
    going = 0
    for i in range(solver.n):
        g = group.running[i] - group.first
        if not flags[g, jl.DONE]:
            if flags[g, jl.CONTACTS_HELD] and flags[g, jl.ROPES_HELD] and flags[g, jl.WELDS_HELD]:
                flags[g, jl.DONE] = True
            else:
                going += 1
    _tick(solver, P_POSITIONS)
    return going == 0


@implements(order.end, InLanes)
@njit(inline="always")
def _end(solver, params):
    for i in range(solver.n):
        b = solver.group.running[i]
        robot, ground, body = lane(solver.system, solver.bodies, b)
        jl.give(solver.group.lanes, b - solver.group.first, body.body_pos, body.body_vel,
                body.cos, body.sin)
        ph.find_contacts(robot, ground, body, body.body_pos, params)
    _tick(solver, P_FOUND)


@uncounted
def advance_group(system, bodies, params, group, n):
    """One control step of physics for the robots ``group.running[:n]``: what
    :func:`somite.sim.physics.advance` does for each (a robot alone: that function, as eight
    lanes for one robot cost 1.7x its time)."""
    # The lanes first: Numba compiles the callees in this order, and on a cold cache
    # (tasks.warm) another process is compiling ph.advance meanwhile.
    if group.count > 1:
        for i in range(n):
            robot, _, body = lane(system, bodies, group.running[i])
            ph.turn(robot.n_points, body.body_pos, body.cos, body.sin)
        lanes = InLanes(system, bodies, group, n)
        for _ in range(int(params.substeps)):
            physics_step(lanes, params)
        return
    robot, ground, body = lane(system, bodies, group.running[0])
    ph.advance(robot, ground, body, params, int(params.substeps))
