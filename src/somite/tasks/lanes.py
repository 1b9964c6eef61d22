"""The CPU batch kernel: robots of one body advanced in groups (:mod:`somite.sim.group`), as
the lanes of vector instructions.

A group's physics step is :func:`somite.sim.step.step`, the order every backend runs, over an
:class:`InLanes` solver: the joints' set-up, velocity and position passes and the move for all
the group's robots at once, robot by robot in the lanes of vector instructions
(:mod:`somite.sim.joint_lanes`), each robot's arithmetic exactly its own; the contacts' passes
robot by robot on their lanes. What differs per robot (terrain, sensing, the controller) runs
robot by robot through the same :func:`~somite.tasks.episode.start`,
:func:`~somite.tasks.episode.before_physics`, :func:`~somite.tasks.episode.after_physics` and
:func:`~somite.tasks.episode.finish` as the CUDA kernel and the stepper. So an outcome is bit for
bit what :func:`somite.sim.physics.advance` gives the robot alone. Groups are spread over the
cores by :func:`somite._threads.spread`. A benchmark may ask the kernel to time its own parts
(:data:`PARTS`, ``benchmarks/passes.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.typed import List

from .._cycles import cycles, tick
from .._jit import njit, uncounted
from .._threads import spread
from ..sim import joint_lanes as jl
from ..sim import physics as ph
from ..sim import step as order
from ..sim.group import GROUP_SIZE, Group, groups, new_group
from ..sim.sensors import lidar_rays
from ..sim.step import implements
from ..sim.step import step as physics_step
from .episode import (
    STATUS_OK,
    Batch,
    after_physics,
    before_physics,
    filled_state,
    finish,
    new_work,
    robot_state,
    start,
    uncounted_work_row,
    work_row,
)

__all__ = ["GROUP_SIZE", "NOT_TIMED", "PARTS", "Batch", "Group", "InLanes", "groups",
           "new_groups", "run_batch", "run_groups", "step_group", "step_groups"]

PARTS = ("gravity, damping, contacts' set-up, into the lanes", "joints: set-up",
         "joints: velocity passes", "contacts: velocity passes", "move and rotations",
         "position passes (contacts, ropes, welds)", "out of the lanes, contacts found",
         "rest lengths", "sensing, controller, diagnostics")
"""The parts of a control step that a timed group (``spent`` with rows) counts cycles of."""
(P_START, P_JOINTS_START, P_JOINTS, P_CONTACTS, P_MOVE, P_POSITIONS, P_FOUND, P_REST,
 P_SENSE) = range(len(PARTS))
NOT_TIMED = np.zeros(0, dtype=np.uint64)
"""``spent`` of a group run that is not being timed."""
NO_ACTUATION = np.zeros((0, 0))
"""``given`` of a control step whose actuation is the controllers' own."""


@njit(inline="always")
def _lane(batch, b):
    # Only in kernels compiled without reference counting (uncounted_work_row).
    return filled_state(batch.system, b,
                        uncounted_work_row(batch.work, b, batch.system, batch.ctrl), batch.rays)


@njit
def _group(batch, first, count, spent):
    """The :class:`~somite.sim.group.Group` of robots ``first .. first + count - 1``, every
    lane holding robot ``first``'s state (a lane no robot uses keeps computing on it,
    harmlessly)."""
    blocks = batch.work.blocks
    group = new_group(batch.system, first, count,
                      (blocks.inv_mass[first], blocks.inv_inertia[first]), spent)
    for g in range(jl.LANES):
        jl.take(group.lanes, g, blocks.body_pos[first], blocks.body_vel[first],
                blocks.cos[first], blocks.sin[first])
    return group


class InLanes(NamedTuple):
    """The robots ``group.running[:n]`` of a batch's group as a solver of
    :func:`somite.sim.step.step`: the joints' passes and the move in the group's lanes, the
    contacts' passes robot by robot on their lanes; each phase adds its cycles to
    ``group.spent`` when that has rows (:data:`PARTS`)."""

    batch: Batch
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
        state = _lane(solver.batch, b)
        w = state.work.blocks
        ph.velocities(state.robot, w.body_vel, params)
        ph.start_contacts(state.robot, state.scratch, w.body_pos, w.body_vel, params)
        jl.take(solver.group.lanes, b - solver.group.first, w.body_pos, w.body_vel, w.cos, w.sin)
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
        state = _lane(solver.batch, b)
        ph.solve_contacts(state.robot, state.scratch,
                          solver.group.lanes.vel[:, :, b - solver.group.first])
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
            state = _lane(solver.batch, group.running[i])
            flags[g, jl.CONTACTS_HELD] = ph.fix_contacts(
                state.robot, state.scratch, lanes.pos[:, :, g], lanes.cos[:, g], lanes.sin[:, g])
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
        state = _lane(solver.batch, b)
        w = state.work.blocks
        jl.give(solver.group.lanes, b - solver.group.first, w.body_pos, w.body_vel, w.cos, w.sin)
        ph.find_contacts(state.robot, state.ground, state.scratch, w.body_pos, params)
    _tick(solver, P_FOUND)


@uncounted
def advance_group(batch, group, n):
    """One control step of physics for the robots ``group.running[:n]``: what
    :func:`somite.sim.physics.advance` does for each (a robot alone: that function, as eight
    lanes for one robot cost 1.7x its time)."""
    params = batch.params
    # The lanes first: Numba compiles the callees in this order, and on a cold cache
    # (tasks.warm) another process is compiling ph.advance meanwhile.
    if group.count > 1:
        for i in range(n):
            state = _lane(batch, group.running[i])
            ph.turn(state.robot.n_points, state.work.blocks.body_pos, state.scratch.cos,
                    state.scratch.sin)
        lanes = InLanes(batch, group, n)
        for _ in range(int(params.substeps)):
            physics_step(lanes, params)
        return
    state = _lane(batch, group.running[0])
    ph.advance(state.robot, state.ground, state.scratch, state.work.blocks.body_pos,
               state.work.blocks.body_vel, params, int(params.substeps))


@njit(inline="always")
def _control_step(k, batch, group, n, given):
    """Control step ``k`` of the robots ``group.running[:n]``; ``given`` (B, V) replaces their
    actuation in force over the step (0 rows: the controllers' own; the stepper's
    ``Episode.step(a)``). Moves the robots still running to the front of ``group.running``
    and returns how many there are."""
    params, running, spent, trace = batch.params, group.running, group.spent, batch.trace
    timed = spent.shape[0] > 0
    clock = cycles() if timed else 0
    for i in range(n):
        b = running[i]
        state = _lane(batch, b)
        actuation = state.work.brain.actuation
        if given.shape[0] > 0:
            # What was in force over step k is what the trace shows at step k - 1, which
            # decided it.
            for v in range(actuation.shape[0]):
                actuation[v] = given[b, v]
                if trace.pos.shape[0] > 0:
                    trace.actuation[b, k - 1, v] = given[b, v]
        rest = state.scratch.rest if group.count == 1 else group.lanes.rest[:, b - group.first]
        before_physics(state.robot, actuation, params, rest)
    clock = tick(spent, P_REST, clock, timed)
    advance_group(batch, group, n)
    clock = cycles() if timed else 0
    going = 0
    for i in range(n):
        b = running[i]
        if after_physics(k, b, batch, _lane(batch, b)):
            running[going] = b
            going += 1
    tick(spent, P_SENSE, clock, timed)
    return going


@uncounted
def control_steps(batch, group):
    """Control steps 1 .. ``batch.n_steps`` of the group's robots. Compiled without reference
    counting (:func:`somite._jit.uncounted`)."""
    n = group.count
    for k in range(1, batch.n_steps + 1):
        n = _control_step(k, batch, group, n, NO_ACTUATION)
        if n == 0:
            break


@uncounted
def step_group(k, batch, group, given):
    """Control step ``k`` of the group's robots still running, as :func:`control_steps` takes
    it (the stepper's, :class:`somite.tasks.stepper.Episode`), and their outcomes so far into
    the trace (``finish``); ``given`` as for :func:`_control_step`."""
    n = 0
    for b in range(group.first, group.first + group.count):
        # control_steps keeps its running robots in this order.
        if batch.trace.status[b] == STATUS_OK:
            group.running[n] = b
            n += 1
    if n > 0:
        _control_step(k, batch, group, n, given)
    for b in range(group.first, group.first + group.count):
        finish(b, batch.trace, _lane(batch, b))


@njit
def new_groups(batch, first, count, spent):
    """The :class:`~somite.sim.group.Group` of every group (``first``, ``count``) of a batch
    whose robots have started, as a typed list: what the stepper keeps between control steps
    (the lanes' warm-start impulses live in the groups) and hands to :func:`step_groups` in one
    argument."""
    out = List()
    for g in range(first.shape[0]):
        out.append(_group(batch, first[g], count[g], spent))
    return out


@njit
def step_groups(k, batch, given, groups, j, stride):
    """:func:`step_group` of groups j, j + stride, j + 2 stride, ... of ``groups``."""
    for g in range(j, len(groups), stride):
        step_group(k, batch, groups[g], given)


@njit
def run_group(batch, first, count, spent):
    """The episodes of robots ``first .. first + count - 1``, control step by control step
    (``spent``: the cycles of each part of :data:`PARTS` are added to it when it has rows,
    see :class:`InLanes`)."""
    system, work = batch.system, batch.work
    for b in range(first, first + count):
        start(b, system, batch.params, batch.trace,
              robot_state(system, b, batch.params, work_row(work, b, system, batch.ctrl),
                          batch.rays))
    control_steps(batch, _group(batch, first, count, spent))
    for b in range(first, first + count):
        finish(b, batch.trace, filled_state(system, b, work_row(work, b, system, batch.ctrl),
                                            batch.rays))


def run_groups(batch: Batch, first, count) -> None:
    """Every group's episodes (:func:`run_group`), the groups handed out to the threads one at
    a time, as robots take unequal times (graph sizes, contacts)."""

    def one(g: int) -> None:
        run_group(batch, first[g], count[g], NOT_TIMED)

    spread(one, first.shape[0])


def run_batch(system, ctrl, params, noise, seeds, n_steps, trace) -> None:
    """Run every robot of the batch into ``trace`` (the CPU backend)."""
    from .warm import finish_sharing, share_first_compile  # it imports this module

    first, count = groups(system)
    batch = Batch(system, ctrl, params, noise, seeds, n_steps, trace,
                  new_work(system, ctrl, params), lidar_rays(params))
    helper = share_first_compile(batch, first, count)
    try:
        run_groups(batch, first, count)
    except BaseException:
        finish_sharing(helper, at_once=True)
        raise
    finish_sharing(helper)
