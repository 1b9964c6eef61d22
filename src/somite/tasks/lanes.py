"""The CPU batch kernel: robots advanced in groups, their joints interleaved.

A physics step is mostly sequential-impulse passes over a robot's joints (springs, rope limits,
welds: over 80% of a worm's control step, ``benchmarks/passes.py``), and each joint's impulse
waits for the one before it (Gauss-Seidel), so one robot's pass is a chain of dependent
arithmetic and the core idles on its latency. A group (up to :data:`GROUP_SIZE` neighbours in the
batch with the same numbers of blocks, springs, ropes and welds) has its joints solved as those
of one robot (:func:`_merged`): joint j of robot 1, of robot 2, ..., then joint j + 1, so that
consecutive joints are independent and the core overlaps them. The joint passes are
:mod:`somite.sim.physics`'s own, and each robot's joints are taken in its own order, so an outcome
is bit for bit what :func:`somite.sim.physics.advance` gives the robot alone; what differs per
robot (contacts, terrain, sensing, the controller) runs robot by robot, through the same
:func:`~somite.tasks.episode.start`, :func:`~somite.tasks.episode.before_physics`,
:func:`~somite.tasks.episode.after_physics` and :func:`~somite.tasks.episode.finish` as the
CUDA kernel and the stepper. Groups are spread over the cores by :func:`somite._threads.spread`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import njit
from .._threads import spread
from ..sim import physics as ph
from ..sim.robot import Robot, Scratch, robot_over
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

GROUP_SIZE = 8
"""Robots a group interleaves at most (96 worms, 2 threads: groups of 1 ran 27.9k
robot-control-steps a second, of 8 40.7k, of 16 37.9k; BENCHMARKS.md)."""

# Columns of a group's flags, one row a robot: its position passes are over; what this pass
# found of its contacts, ropes, welds.
F_DONE, F_CONTACTS, F_ROPES, F_WELDS = range(4)


def groups(system, group_size: int = GROUP_SIZE, threads: int | None = None):
    """(first, count) arrays: consecutive robots with the same joint counts, at most
    ``group_size`` a group and small enough that every thread gets one."""
    n = system.n_points.shape[0]
    threads = threads or numba.get_num_threads()
    size = max(1, min(group_size, math.ceil(n / threads)))
    key = np.stack([system.n_points, system.n_springs, system.n_ropes, system.n_welds], axis=1)
    first, count = [], []
    for b in range(n):
        if count and count[-1] < size and (key[b] == key[first[-1]]).all():
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
def _merged(system, work, params, first, count):
    """The joints of robots ``first .. first + count - 1`` as those of one robot whose bodies
    are theirs (robot i's body p is body i * P + p, P the batch's padded block count, as the
    batch's rows lie in memory) and whose joint j * count + i is robot i's joint j: one pass
    over it is a pass over each robot's joints in that robot's order, the robots taking each
    joint in turn. Returns (robot, scratch) for the joint passes of :mod:`somite.sim.physics`
    and a fresh set of the joints' work rows."""
    robot = robot_over(system, first, work.inv_mass[first], work.inv_inertia[first])
    width = work.body_pos.shape[1]
    s, y, q = robot.n_springs, robot.n_ropes, robot.n_welds
    ends = np.empty((s * count, 2), dtype=np.int32)
    anchor = np.empty((s * count, 4))
    kind = np.empty(s * count, dtype=np.int32)
    owner = np.empty(s * count, dtype=np.int32)
    rope_ends = np.empty((y * count, 2), dtype=np.int32)
    weld_ends = np.empty((q * count, 2), dtype=np.int32)
    weld_anchor = np.empty((q * count, 2))
    for i in range(count):
        b = first + i
        base = i * width
        for j in range(s):
            m = j * count + i
            ends[m, 0] = system.spring_ends[b, j, 0] + base
            ends[m, 1] = system.spring_ends[b, j, 1] + base
            for c in range(4):
                anchor[m, c] = system.spring_anchor[b, j, c]
            kind[m] = system.spring_kind[b, j]
            owner[m] = system.spring_owner[b, j]
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
        width * count, s * count, y * count, q * count, robot.n_pairs, robot.n_voxels, ends,
        anchor, kind, owner, rope_ends, weld_ends, weld_anchor, robot.pair_ends, robot.mass,
        work.inv_mass[first:last].reshape(width * count),
        work.inv_inertia[first:last].reshape(width * count), robot.corner_offset,
        robot.corners)
    b = first
    scratch = Scratch(
        np.zeros(s * count), work.cos[first:last].reshape(width * count),
        work.sin[first:last].reshape(width * count),
        np.zeros((s * count, ph.N_SPRING_COLUMNS)), np.zeros((y * count, ph.N_ROPE_COLUMNS)),
        np.zeros((q * count, ph.N_WELD_COLUMNS)), work.contacts[b], work.previous[b],
        work.counts[b], work.polygon[b], work.clipped[b], work.contact[b], work.segment[b])
    pos = work.body_pos[first:last].reshape(width * count, 3)
    vel = work.body_vel[first:last].reshape(width * count, 3)
    return merged, scratch, pos, vel


@njit(inline="always")
def _step(system, ctrl, work, params, rays, joints, scratch, pos, vel, first, lanes, n, count,
          flags):
    """:func:`somite.sim.physics.step` for each robot of ``lanes[:n]`` (the robots still
    running of the group of ``count`` from ``first``), pass by pass; the joints' passes over
    all the group's robots at once (:func:`_merged`: a robot that stopped keeps its own
    bodies, which no other robot's joint touches). ``flags``' row of robot b is b - first."""
    for i in range(n):
        state = _lane(system, ctrl, work, rays, lanes[i])
        w = state.work
        ph.velocities(state.robot, w.body_vel, params)
        ph.start_contacts(state.robot, state.scratch, w.body_pos, w.body_vel, params)
    ph.start_springs(joints, scratch, pos, vel, params)
    ph.start_ropes(joints, scratch, pos, vel)
    ph.start_welds(joints, scratch, vel)
    for _ in range(params.velocity_iterations):
        ph.solve_springs(joints, scratch, vel)
        ph.solve_ropes(joints, scratch, vel)
        ph.solve_welds(joints, scratch, vel)
        for i in range(n):
            state = _lane(system, ctrl, work, rays, lanes[i])
            ph.solve_contacts(state.robot, state.scratch, state.work.body_vel)
    for i in range(count):
        flags[i, F_DONE] = True
    for i in range(n):
        state = _lane(system, ctrl, work, rays, lanes[i])
        ph.positions(state.robot, state.scratch, state.work.body_pos, state.work.body_vel,
                     params)
        flags[lanes[i] - first, F_DONE] = False
    for _ in range(params.position_iterations):
        for i in range(n):
            g = lanes[i] - first
            if flags[g, F_DONE]:
                continue
            state = _lane(system, ctrl, work, rays, lanes[i])
            flags[g, F_CONTACTS] = ph.fix_contacts(state.robot, state.scratch,
                                                   state.work.body_pos)
            flags[g, F_ROPES] = flags[g, F_WELDS] = True
        ends = joints.rope_ends
        for m in range(joints.n_ropes):
            g = m % count
            if flags[g, F_DONE]:
                continue
            if not ph.rope_fix(ends[m, 0], ends[m, 1], pos, joints.inv_mass,
                               joints.inv_inertia):
                flags[g, F_ROPES] = False
        ends = joints.weld_ends
        for m in range(joints.n_welds):
            g = m % count
            if flags[g, F_DONE]:
                continue
            if not ph.weld_fix(m, ends[m, 0], ends[m, 1], joints.weld_anchor, pos, scratch.cos,
                               scratch.sin, joints.inv_mass, joints.inv_inertia):
                flags[g, F_WELDS] = False
        going = 0
        for i in range(n):
            g = lanes[i] - first
            if not flags[g, F_DONE]:
                if flags[g, F_CONTACTS] and flags[g, F_ROPES] and flags[g, F_WELDS]:
                    flags[g, F_DONE] = True
                else:
                    going += 1
        if going == 0:
            break
    for i in range(n):
        state = _lane(system, ctrl, work, rays, lanes[i])
        ph.find_contacts(state.robot, state.ground, state.scratch, state.work.body_pos, params)


@njit(_nrt=False)
def advance_group(system, ctrl, work, params, rays, joints, scratch, pos, vel, first, lanes, n,
                  count, flags):
    """One control step of physics for the robots ``lanes[:n]`` of a group of ``count``:
    what :func:`somite.sim.physics.advance` does for each."""
    for i in range(n):
        state = _lane(system, ctrl, work, rays, lanes[i])
        ph.turn(state.robot.n_points, state.work.body_pos, state.scratch.cos, state.scratch.sin)
    for _ in range(int(params.substeps)):
        _step(system, ctrl, work, params, rays, joints, scratch, pos, vel, first, lanes, n, count,
              flags)


@njit(_nrt=False)
def _steps(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count, lanes,
           flags, joints, scratch, pos, vel, rest):
    """Control steps 1 .. ``n_steps`` of the group's robots. Compiled without reference
    counting: every view of the batch's arrays taken here would otherwise cost an atomic
    increment and decrement of a counter that the other threads' groups share too (the batch
    kernel ran 10-15% slower on 2 threads)."""
    n = count
    for k in range(1, n_steps + 1):
        for i in range(n):
            g = lanes[i] - first
            state = _lane(system, ctrl, work, rays, lanes[i])
            before_physics(state.robot, state.work.actuation, params, rest[:, g])
        advance_group(system, ctrl, work, params, rays, joints, scratch, pos, vel, first, lanes,
                      n, count, flags)
        going = 0
        for i in range(n):
            b = lanes[i]
            if after_physics(k, b, system, ctrl, params, noise, seeds[b], trace,
                             _lane(system, ctrl, work, rays, b)):
                lanes[going] = b
                going += 1
        n = going
        if n == 0:
            break


@njit
def run_group(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count):
    """The episodes of robots ``first .. first + count - 1``, control step by control step."""
    lanes = np.empty(count, dtype=np.int64)
    flags = np.empty((count, 4), dtype=np.bool_)
    for i in range(count):
        b = first + i
        lanes[i] = b
        start(b, system, params, trace, robot_state(system, b, params,
                                                    work_row(work, b, system, ctrl), rays))
    joints, scratch, pos, vel = _merged(system, work, params, first, count)
    rest = scratch.rest.reshape(joints.n_springs // count, count)
    _steps(system, ctrl, params, noise, seeds, n_steps, trace, work, rays, first, count, lanes,
           flags, joints, scratch, pos, vel, rest)
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
