"""The CPU batch kernel: robots of one body advanced in groups, as the lanes of vector
instructions (:mod:`somite.sim.group`).

A group's physics is :func:`somite.sim.group.advance_group` over the batch's
:class:`~somite.sim.state.BodyState` rows (``batch.work.physics``). What differs per robot
(terrain, sensing, the controller) runs robot by robot through the same
:func:`~somite.tasks.episode.start`, :func:`~somite.tasks.episode.before_physics`,
:func:`~somite.tasks.episode.after_physics` and :func:`~somite.tasks.episode.finish` as the CUDA
kernel and the stepper. So an outcome is bit for bit what :func:`somite.sim.physics.advance`
gives the robot alone. Groups are spread over the cores by :func:`somite._threads.spread`. A
benchmark may ask the kernel to time its own parts (:data:`PARTS`, ``benchmarks/passes.py``).
"""

from __future__ import annotations

import numpy as np
from numba.typed import List

from .._cycles import cycles, tick
from .._jit import njit, uncounted
from .._threads import spread
from ..sim.group import (
    GROUP_SIZE,
    NOT_TIMED,
    P_REST,
    P_SENSE,
    PARTS,
    Group,
    InLanes,
    advance_group,
    groups,
    start_group,
)
from ..sim.sensors import lidar_rays
from .episode import (
    STATUS_OK,
    Batch,
    after_physics,
    before_physics,
    filled_state,
    finish,
    robot_state,
    start,
    uncounted_work_row,
    work_row,
)
from .work import new_work

__all__ = ["GROUP_SIZE", "NOT_TIMED", "PARTS", "Batch", "Group", "InLanes", "groups",
           "new_groups", "run_batch", "run_groups", "step_group", "step_groups"]

NO_ACTUATION = np.zeros((0, 0))
"""``given`` of a control step whose actuation is the controllers' own."""


@njit(inline="always")
def _lane(batch, b):
    # Only in kernels compiled without reference counting (uncounted_work_row).
    return filled_state(batch.system, b, uncounted_work_row(batch.work, b, batch.system,
                                                            batch.ctrl, batch.params),
                        batch.rays)


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
        rest = (state.work.physics.rest if group.count == 1
                else group.lanes.rest[:, b - group.first])
        before_physics(state.robot, actuation, params, rest)
    clock = tick(spent, P_REST, clock, timed)
    advance_group(batch.system, batch.work.physics, params, group, n)
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
        out.append(start_group(batch.system, batch.work.physics, first[g], count[g], spent))
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
              robot_state(system, b, batch.params,
                          work_row(work, b, system, batch.ctrl, batch.params), batch.rays))
    control_steps(batch, start_group(system, work.physics, first, count, spent))
    for b in range(first, first + count):
        finish(b, batch.trace, filled_state(
            system, b, work_row(work, b, system, batch.ctrl, batch.params), batch.rays))


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
