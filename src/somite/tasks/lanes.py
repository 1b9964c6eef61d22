"""The CPU batch kernel: robots of one body advanced in groups, as the lanes of vector
instructions.

A physics step is mostly sequential-impulse passes over a robot's joints (springs, rope limits,
welds), and each joint's impulse waits for the one before it (Gauss-Seidel), so one robot's pass
is a chain of dependent arithmetic. Every robot of a group (up to :data:`GROUP_SIZE` neighbours
in the batch with the same body) has the same joints, so the group's step runs in
:class:`~somite.sim.joint_lanes.Lanes`, robots innermost: the joints' set-up, velocity and
position passes and the move for all the group's robots at once, robot by robot in the lanes of
vector instructions (:mod:`somite.sim.joint_lanes`), each robot's arithmetic exactly its own.
What differs per robot (contacts, terrain, sensing, the controller) runs robot by robot, the
contacts' passes on the robot's lane, through the same :func:`~somite.tasks.episode.start`,
:func:`~somite.tasks.episode.before_physics`, :func:`~somite.tasks.episode.after_physics` and
:func:`~somite.tasks.episode.finish` as the CUDA kernel and the stepper. So an outcome is bit for
bit what :func:`somite.sim.physics.advance` gives the robot alone. Groups are spread over the
cores by :func:`somite._threads.spread`. A benchmark may ask the kernel to time its own parts
(:data:`PARTS`, ``benchmarks/passes.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._cycles import cycles, tick
from .._jit import njit, uncounted
from .._threads import spread
from ..sim import joint_lanes as jl
from ..sim import physics as ph
from ..sim.config import Params
from ..sim.sensors import lidar_rays
from ..sim.system import System
from .episode import (
    Controllers,
    Trace,
    Work,
    after_physics,
    before_physics,
    borrowed_work_row,
    finish,
    new_work,
    robot_state,
    start,
    state_over,
    work_row,
)

GROUP_SIZE = jl.LANES
"""Robots a group advances together at most."""

PARTS = ("gravity, damping, contacts' set-up, into the lanes", "joints: set-up",
         "joints: velocity passes", "contacts: velocity passes", "move and rotations",
         "position passes (contacts, ropes, welds)", "out of the lanes, contacts found",
         "rest lengths", "sensing, controller, diagnostics")
"""The parts of a control step that a timed group (``spent`` with rows) counts cycles of."""
(P_START, P_JOINTS_START, P_JOINTS, P_CONTACTS, P_MOVE, P_POSITIONS, P_FOUND, P_REST,
 P_SENSE) = range(len(PARTS))
NOT_TIMED = np.zeros(0, dtype=np.uint64)
"""``spent`` of a group run that is not being timed."""


def _body_key(system, b: int) -> bytes:
    """What robots of one group must share: their joints and their blocks' masses."""
    p, s = system.n_points[b], system.n_springs[b]
    y, q = system.n_ropes[b], system.n_welds[b]
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (
        np.array([p, s, y, q]), system.spring_ends[b, :s], system.spring_anchor[b, :s],
        system.rope_ends[b, :y], system.weld_ends[b, :q], system.weld_anchor[b, :q],
        system.mass[b, :p], system.inertia[b, :p]))


def groups(system, group_size: int = GROUP_SIZE, threads: int | None = None):
    """(first, count) arrays: consecutive robots with the same body (:func:`_body_key`), at
    most ``group_size`` a group and small enough that every thread gets one."""
    n = system.n_points.shape[0]
    threads = threads or numba.get_num_threads()
    size = max(1, min(group_size, math.ceil(n / threads)))
    key = [_body_key(system, b) for b in range(n)]
    first, count = [], []
    for b in range(n):
        if count and count[-1] < size and key[b] == key[first[-1]]:
            count[-1] += 1
        else:
            first.append(b)
            count.append(1)
    return np.array(first, dtype=np.int64), np.array(count, dtype=np.int64)


class Batch(NamedTuple):
    """What every group of a batch reads (and writes into: ``trace``, its rows of ``work``)."""

    system: System
    ctrl: Controllers
    params: Params
    noise: np.ndarray  # noise_table(config)
    seeds: np.ndarray  # (B,) uint64
    n_steps: int
    trace: Trace
    work: Work
    rays: np.ndarray  # lidar_rays(params)


class Group(NamedTuple):
    """The robots ``first .. first + count - 1`` of a batch, all of one body, as they advance
    together: robot b's lane and ``flags`` row (:data:`~somite.sim.joint_lanes.DONE`, ...) are
    b - first; ``running`` holds the robots still running first."""

    first: int
    count: int
    lanes: jl.Lanes
    running: np.ndarray  # (count,) int64
    flags: np.ndarray  # (LANES, 4) bool
    spent: np.ndarray  # cycles per part of PARTS (a benchmark), or no rows


@njit(inline="always")
def _lane(batch, b):
    # Only in kernels compiled without reference counting (borrowed_work_row).
    return state_over(batch.system, b,
                      borrowed_work_row(batch.work, b, batch.system, batch.ctrl), batch.rays)


@njit
def _lanes(system, work, first):
    """The :class:`~somite.sim.joint_lanes.Lanes` of a group from ``first``, every lane
    holding robot ``first``'s state (a lane no robot uses keeps computing on it, harmlessly)."""
    p, s = system.n_points[first], system.n_springs[first]
    y, q = system.n_ropes[first], system.n_welds[first]
    width = jl.LANES
    lanes = jl.Lanes(
        system.spring_ends[first, :s].copy(), system.spring_anchor[first, :s].copy(),
        system.rope_ends[first, :y].copy(), system.weld_ends[first, :q].copy(),
        system.weld_anchor[first, :q].copy(), work.inv_mass[first, :p].copy(),
        work.inv_inertia[first, :p].copy(), np.empty((p, 3, width)), np.empty((p, 3, width)),
        np.empty((p, width)), np.empty((p, width)), np.zeros((s, width)),
        np.zeros((s, ph.N_SPRING_COLUMNS, width)), np.zeros((y, ph.N_ROPE_COLUMNS, width)),
        np.zeros((q, ph.N_WELD_COLUMNS, width)))
    for g in range(width):
        jl.take(lanes, g, work.body_pos[first], work.body_vel[first], work.cos[first],
                work.sin[first])
    return lanes


@njit(inline="always")
def fix_positions(batch, group, n):
    """The position passes of the robots ``group.running[:n]`` (their contacts robot by robot
    on their lanes, their rope limits and welds in the lanes), until each robot's contacts and
    joints hold or ``params.position_iterations`` passes are done. A running robot's ``flags``
    row starts with DONE False, every other row with DONE True."""
    lanes, flags = group.lanes, group.flags
    for _ in range(batch.params.position_iterations):
        for i in range(n):
            g = group.running[i] - group.first
            if not flags[g, jl.DONE]:
                state = _lane(batch, group.running[i])
                flags[g, jl.CONTACTS_HELD] = ph.fix_contacts(
                    state.robot, state.scratch, lanes.pos[:, :, g], lanes.cos[:, g],
                    lanes.sin[:, g])
        jl.fix_joints(lanes, flags)
        going = 0
        for i in range(n):
            g = group.running[i] - group.first
            if not flags[g, jl.DONE]:
                if (flags[g, jl.CONTACTS_HELD] and flags[g, jl.ROPES_HELD]
                        and flags[g, jl.WELDS_HELD]):
                    flags[g, jl.DONE] = True
                else:
                    going += 1
        if going == 0:
            break


@njit(inline="always")
def step(batch, group, n):
    """:func:`somite.sim.physics.step` for each robot of ``group.running[:n]``, pass by pass,
    in the group's lanes but for the contacts, which run robot by robot on their lanes; with
    the cycles of each part (:data:`PARTS`) added to ``group.spent`` when it has rows."""
    params, lanes, running, first, spent = (batch.params, group.lanes, group.running,
                                            group.first, group.spent)
    timed = spent.shape[0] > 0
    clock = cycles() if timed else 0
    for i in range(n):
        state = _lane(batch, running[i])
        w = state.work
        ph.velocities(state.robot, w.body_vel, params)
        ph.start_contacts(state.robot, state.scratch, w.body_pos, w.body_vel, params)
        jl.take(lanes, running[i] - first, w.body_pos, w.body_vel, w.cos, w.sin)
    clock = tick(spent, P_START, clock, timed)
    jl.start_joints(lanes, params)
    clock = tick(spent, P_JOINTS_START, clock, timed)
    for _ in range(params.velocity_iterations):
        jl.solve_joints(lanes)
        clock = tick(spent, P_JOINTS, clock, timed)
        for i in range(n):
            state = _lane(batch, running[i])
            ph.solve_contacts(state.robot, state.scratch, lanes.vel[:, :, running[i] - first])
        clock = tick(spent, P_CONTACTS, clock, timed)
    jl.move(lanes.pos, lanes.vel, lanes.cos, lanes.sin, params.dt)
    clock = tick(spent, P_MOVE, clock, timed)
    for g in range(group.flags.shape[0]):
        group.flags[g, jl.DONE] = True
    for i in range(n):
        group.flags[running[i] - first, jl.DONE] = False
    fix_positions(batch, group, n)
    clock = tick(spent, P_POSITIONS, clock, timed)
    for i in range(n):
        state = _lane(batch, running[i])
        w = state.work
        jl.give(lanes, running[i] - first, w.body_pos, w.body_vel, w.cos, w.sin)
        ph.find_contacts(state.robot, state.ground, state.scratch, w.body_pos, params)
    tick(spent, P_FOUND, clock, timed)


@uncounted
def advance_group(batch, group, n):
    """One control step of physics for the robots ``group.running[:n]``: what
    :func:`somite.sim.physics.advance` does for each (a robot alone: that function, as eight
    lanes for one robot cost 1.7x its time)."""
    params = batch.params
    if group.count == 1:
        state = _lane(batch, group.running[0])
        ph.advance(state.robot, state.ground, state.scratch, state.work.body_pos,
                   state.work.body_vel, params, int(params.substeps))
        return
    for i in range(n):
        state = _lane(batch, group.running[i])
        ph.turn(state.robot.n_points, state.work.body_pos, state.scratch.cos, state.scratch.sin)
    for _ in range(int(params.substeps)):
        step(batch, group, n)


@uncounted
def control_steps(batch, group):
    """Control steps 1 .. ``batch.n_steps`` of the group's robots. Compiled without reference
    counting (:func:`somite._jit.uncounted`)."""
    params, running, spent = batch.params, group.running, group.spent
    n = group.count
    timed = spent.shape[0] > 0
    for k in range(1, batch.n_steps + 1):
        clock = cycles() if timed else 0
        for i in range(n):
            state = _lane(batch, running[i])
            rest = (state.scratch.rest if group.count == 1
                    else group.lanes.rest[:, running[i] - group.first])
            before_physics(state.robot, state.work.actuation, params, rest)
        clock = tick(spent, P_REST, clock, timed)
        advance_group(batch, group, n)
        clock = cycles() if timed else 0
        going = 0
        for i in range(n):
            b = running[i]
            if after_physics(k, b, batch.system, batch.ctrl, params, batch.noise,
                             batch.seeds[b], batch.trace, _lane(batch, b)):
                running[going] = b
                going += 1
        tick(spent, P_SENSE, clock, timed)
        n = going
        if n == 0:
            break


@njit
def run_group(batch, first, count, spent):
    """The episodes of robots ``first .. first + count - 1``, control step by control step
    (``spent``: see :func:`step`)."""
    system, work = batch.system, batch.work
    for b in range(first, first + count):
        start(b, system, batch.params, batch.trace,
              robot_state(system, b, batch.params, work_row(work, b, system, batch.ctrl),
                          batch.rays))
    control_steps(batch, Group(first, count, _lanes(system, work, first),
                               np.arange(first, first + count),
                               np.empty((jl.LANES, 4), dtype=np.bool_), spent))
    for b in range(first, first + count):
        finish(b, batch.trace, state_over(system, b, work_row(work, b, system, batch.ctrl),
                                          batch.rays))


def run_groups(batch: Batch, first, count) -> None:
    """Every group's episodes (:func:`run_group`), the groups handed out to the threads one at
    a time, as robots take unequal times (graph sizes, contacts)."""

    def one(g: int) -> None:
        run_group(batch, first[g], count[g], NOT_TIMED)

    spread(one, first.shape[0])


def run_batch(system, ctrl, params, noise, seeds, n_steps, trace) -> None:
    """Run every robot of the batch into ``trace`` (the CPU backend)."""
    first, count = groups(system)
    run_groups(Batch(system, ctrl, params, noise, seeds, n_steps, trace,
                     new_work(system, ctrl, params), lidar_rays(params)), first, count)
