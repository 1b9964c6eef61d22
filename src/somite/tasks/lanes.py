"""The CPU batch kernel: robots of one body advanced in groups, as the lanes of vector
instructions.

A physics step is mostly sequential-impulse passes over a robot's joints (springs, rope limits,
welds: over 80% of a worm's control step, ``benchmarks/passes.py``), and each joint's impulse
waits for the one before it (Gauss-Seidel), so one robot's pass is a chain of dependent
arithmetic. Every robot of a group (up to :data:`GROUP_SIZE` neighbours in the batch with the
same body) has the same joints, so their velocity passes run at once, robot by robot in the
lanes of vector instructions (:mod:`somite.sim.joint_lanes`), each robot's arithmetic exactly its
own; the position passes run over the group's robots as those of one robot (:func:`_merged`:
joint j of robot 1, of robot 2, ..., then joint j + 1), each robot's joints in its own order. So
an outcome is bit for bit what :func:`somite.sim.physics.advance` gives the robot alone; what
differs per robot (contacts, terrain, sensing, the controller) runs robot by robot, through the
same :func:`~somite.tasks.episode.start`, :func:`~somite.tasks.episode.before_physics`,
:func:`~somite.tasks.episode.after_physics` and :func:`~somite.tasks.episode.finish` as the
CUDA kernel and the stepper. Groups are spread over the cores by :func:`somite._threads.spread`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import njit
from .._threads import spread
from ..sim import joint_lanes as jl
from ..sim import physics as ph
from ..sim.robot import Robot, robot_over
from ..sim.sensors import lidar_rays
from .episode import (
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

# Columns of a group's flags, one row a robot: its position passes are over; what this pass
# found of its contacts, ropes, welds.
F_DONE, F_CONTACTS, F_ROPES, F_WELDS = range(4)


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


@njit(inline="always")
def _lane(system, ctrl, work, rays, b):
    # Only in kernels compiled without reference counting (borrowed_work_row).
    return state_over(system, b, borrowed_work_row(work, b, system, ctrl), rays)


@njit
def _merged(system, work, first, count):
    """The rope limits and welds of robots ``first .. first + count - 1`` as those of one robot
    whose bodies are theirs (robot i's body p is body i * P + p, P the batch's padded block
    count, as the batch's rows lie in memory) and whose joint j * count + i is robot i's joint
    j: one position pass over it is a pass over each robot's joints in that robot's order, the
    robots taking each joint in turn. Returns that robot (no springs: they have no position
    pass), the group's rotations and positions as its ``cos``, ``sin`` and ``pos``."""
    robot = robot_over(system, first, work.inv_mass[first], work.inv_inertia[first])
    width = work.body_pos.shape[1]
    y, q = robot.n_ropes, robot.n_welds
    rope_ends = np.empty((y * count, 2), dtype=np.int32)
    weld_ends = np.empty((q * count, 2), dtype=np.int32)
    weld_anchor = np.empty((q * count, 2))
    for i in range(count):
        b = first + i
        base = i * width
        for j in range(y):
            m = j * count + i
            rope_ends[m, 0] = system.rope_ends[b, j, 0] + base
            rope_ends[m, 1] = system.rope_ends[b, j, 1] + base
        for j in range(q):
            m = j * count + i
            weld_ends[m, 0] = system.weld_ends[b, j, 0] + base
            weld_ends[m, 1] = system.weld_ends[b, j, 1] + base
            weld_anchor[m, 0] = system.weld_anchor[b, j, 0]
            weld_anchor[m, 1] = system.weld_anchor[b, j, 1]
    last = first + count
    merged = Robot(
        width * count, 0, y * count, q * count, robot.n_pairs, robot.n_voxels,
        robot.ends[:0], robot.anchor[:0], robot.kind[:0], robot.owner[:0], rope_ends,
        weld_ends, weld_anchor, robot.pair_ends, robot.mass,
        work.inv_mass[first:last].reshape(width * count),
        work.inv_inertia[first:last].reshape(width * count), robot.corner_offset,
        robot.corners)
    return (merged, work.cos[first:last].reshape(width * count),
            work.sin[first:last].reshape(width * count),
            work.body_pos[first:last].reshape(width * count, 3))


@njit
def _lanes(system, work, first, count):
    """The group's :class:`~somite.sim.joint_lanes.Lanes`, every lane holding robot
    ``first``'s state (a lane no robot uses keeps computing on it, harmlessly)."""
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
def fix_positions(system, ctrl, work, params, rays, joints, cos, sin, pos, first, running, n,
                  count, flags):
    """The position passes of the robots ``running[:n]`` (their contacts robot by robot, the
    rope limits and welds of the merged body of :func:`_merged`), until each robot's contacts
    and joints hold or ``params.position_iterations`` passes are done; a running robot's
    ``flags`` row starts False at F_DONE."""
    for _ in range(params.position_iterations):
        for i in range(n):
            g = running[i] - first
            if flags[g, F_DONE]:
                continue
            state = _lane(system, ctrl, work, rays, running[i])
            flags[g, F_CONTACTS] = ph.fix_contacts(state.robot, state.scratch,
                                                   state.work.body_pos)
            flags[g, F_ROPES] = flags[g, F_WELDS] = True
        # Joint m of the merged body is robot g's (m = j * count + g): nested loops, as an
        # integer division a joint cost 0.3 us a robot and step.
        ends = joints.rope_ends
        for j in range(0, joints.n_ropes, count):
            for g in range(count):
                m = j + g
                if not flags[g, F_DONE] and not ph.rope_fix(
                        ends[m, 0], ends[m, 1], pos, joints.inv_mass, joints.inv_inertia):
                    flags[g, F_ROPES] = False
        ends = joints.weld_ends
        for j in range(0, joints.n_welds, count):
            for g in range(count):
                m = j + g
                if not flags[g, F_DONE] and not ph.weld_fix(
                        m, ends[m, 0], ends[m, 1], joints.weld_anchor, pos, cos, sin,
                        joints.inv_mass, joints.inv_inertia):
                    flags[g, F_WELDS] = False
        going = 0
        for i in range(n):
            g = running[i] - first
            if not flags[g, F_DONE]:
                if flags[g, F_CONTACTS] and flags[g, F_ROPES] and flags[g, F_WELDS]:
                    flags[g, F_DONE] = True
                else:
                    going += 1
        if going == 0:
            break


@njit(inline="always")
def _step(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes, first, running, n,
          count, flags):
    """:func:`somite.sim.physics.step` for each robot of ``running[:n]`` (the robots still
    running of the group of ``count`` from ``first``), pass by pass: the joints' velocity
    passes over all the group's robots at once in ``lanes``, their position passes in the
    merged body of :func:`_merged` (a robot that stopped keeps its own bodies, which no other
    robot's joint touches). Robot b's lane and ``flags``' row are b - first."""
    for i in range(n):
        state = _lane(system, ctrl, work, rays, running[i])
        w = state.work
        ph.velocities(state.robot, w.body_vel, params)
        ph.start_contacts(state.robot, state.scratch, w.body_pos, w.body_vel, params)
        jl.take(lanes, running[i] - first, w.body_pos, w.body_vel, w.cos, w.sin)
    jl.start_joints(lanes, params)
    for _ in range(params.velocity_iterations):
        jl.solve_joints(lanes)
        for i in range(n):
            state = _lane(system, ctrl, work, rays, running[i])
            ph.solve_contacts(state.robot, state.scratch, lanes.vel[:, :, running[i] - first])
    for i in range(n):
        jl.give_velocities(lanes, running[i] - first, work.body_vel[running[i]])
    for i in range(count):
        flags[i, F_DONE] = True
    for i in range(n):
        state = _lane(system, ctrl, work, rays, running[i])
        ph.positions(state.robot, state.scratch, state.work.body_pos, state.work.body_vel,
                     params)
        flags[running[i] - first, F_DONE] = False
    fix_positions(system, ctrl, work, params, rays, joints, cos, sin, pos, first, running, n,
                  count, flags)
    for i in range(n):
        state = _lane(system, ctrl, work, rays, running[i])
        ph.find_contacts(state.robot, state.ground, state.scratch, state.work.body_pos, params)


@njit(_nrt=False)
def advance_group(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes, first,
                  running, n, count, flags):
    """One control step of physics for the robots ``running[:n]`` of a group of ``count``:
    what :func:`somite.sim.physics.advance` does for each (a robot alone: that function, as
    eight lanes for one robot cost 1.7x its time)."""
    if count == 1:
        state = _lane(system, ctrl, work, rays, running[0])
        ph.advance(state.robot, state.ground, state.scratch, state.work.body_pos,
                   state.work.body_vel, params, int(params.substeps))
        return
    for i in range(n):
        state = _lane(system, ctrl, work, rays, running[i])
        ph.turn(state.robot.n_points, state.work.body_pos, state.scratch.cos, state.scratch.sin)
    for _ in range(int(params.substeps)):
        _step(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes, first, running, n,
              count, flags)


@njit(_nrt=False)
def _steps(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count,
           running, flags, joints, cos, sin, pos, lanes):
    """Control steps 1 .. ``n_steps`` of the group's robots. Compiled without reference
    counting: every view of the batch's arrays taken here would otherwise cost an atomic
    increment and decrement of a counter that the other threads' groups share too (the batch
    kernel ran 10-15% slower on 2 threads)."""
    n = count
    for k in range(1, n_steps + 1):
        for i in range(n):
            state = _lane(system, ctrl, work, rays, running[i])
            if count == 1:
                before_physics(state.robot, state.work.actuation, params, state.scratch.rest)
            else:
                before_physics(state.robot, state.work.actuation, params,
                               lanes.rest[:, running[i] - first])
        advance_group(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes, first,
                      running, n, count, flags)
        going = 0
        for i in range(n):
            b = running[i]
            if after_physics(k, b, system, ctrl, params, noise, seeds[b], trace,
                             _lane(system, ctrl, work, rays, b)):
                running[going] = b
                going += 1
        n = going
        if n == 0:
            break


@njit
def run_group(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count):
    """The episodes of robots ``first .. first + count - 1``, control step by control step."""
    running = np.empty(count, dtype=np.int64)
    flags = np.empty((count, 4), dtype=np.bool_)
    for i in range(count):
        b = first + i
        running[i] = b
        start(b, system, params, trace, robot_state(system, b, params,
                                                    work_row(work, b, system, ctrl), rays))
    joints, cos, sin, pos = _merged(system, work, first, count)
    _steps(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count, running,
           flags, joints, cos, sin, pos, _lanes(system, work, first, count))
    for i in range(count):
        b = first + i
        finish(b, trace, state_over(system, b, work_row(work, b, system, ctrl), rays))


def run_groups(system, ctrl, params, noise, seeds, n_steps, trace, work, first, count) -> None:
    """Every group's episodes (:func:`run_group`), the groups handed out to the threads one at
    a time, as robots take unequal times (graph sizes, contacts)."""
    rays = lidar_rays(params)

    def one(g: int) -> None:
        run_group(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first[g],
                  count[g])

    spread(one, first.shape[0])


def run_batch(system, ctrl, params, noise, seeds, n_steps, trace) -> None:
    """Run every robot of the batch into ``trace`` (the CPU backend)."""
    first, count = groups(system)
    run_groups(system, ctrl, params, noise, seeds, n_steps, trace,
               new_work(system, ctrl, params), first, count)
