"""Where a control step's time goes, robot by robot: the physics passes one by one, and the rest
of the step.

The paper's workload (``somite bench``'s: random graph controllers of ~200 nodes + edges, each
robot on its own hilly terrain) is run once by the kernel, recording each step's actuation, and
timed whole on one thread. Then each robot's physics is replayed under the recorded actuations
by a copy of ``sim.physics.step`` with the CPU's cycle counter read between its passes; the
replay must end in the kernel's state bit for bit (checked: a copy that falls behind
``physics.step`` fails here). What the replay does not cover (sensing, the controller, the
diagnostics) is the episode's time less the physics'. Prints JSON: microseconds per robot and
control step, and each part's share.

The CPU kernel (``somite.tasks.lanes``) runs groups of robots, their joints' set-up and velocity
passes as vector lanes: ``cpu_kernel`` times it whole on the same batch and replays each group's
physics the same way, through a copy of ``lanes._step`` with the cycles of each part counted
(checked bit for bit like the one above).

    python benchmarks/passes.py [--shape worm] [--robots 24] [--duration 10]
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from somite._jit import njit
from somite.bench import random_graph
from somite.sim import physics as ph
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.sensors import lidar_rays, noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.sim import joint_lanes as jl
from somite.tasks.episode import (
    before_physics,
    episode,
    new_work,
    robot_state,
    robot_work,
    start,
    work_row,
)
from somite.tasks.lanes import F_DONE, _lane, _lanes, _merged, fix_positions, groups
from somite.tasks.locomotion import compile_controllers, run

PASSES = (
    "gravity and damping", "contacts: set-up", "springs: set-up", "ropes: set-up",
    "welds: set-up", "springs: velocity passes", "ropes: velocity passes",
    "welds: velocity passes", "contacts: velocity passes", "move and rotations",
    "contacts: position passes", "ropes: position passes", "welds: position passes",
    "contacts: found",
)
REST_LENGTHS = len(PASSES)  # the rest lengths from the actuation, once a control step
N_SLOTS = REST_LENGTHS + 1
GROUP_PASSES = (
    "gravity and damping, contacts: set-up", "into and out of the lanes",
    "joints: set-up (lanes)", "joints: velocity passes (lanes)", "contacts: velocity passes",
    "move and rotations", "position passes (contacts, ropes, welds)", "contacts: found",
    "rotations and rest lengths",
)


@intrinsic
def _cycles(typingctx):
    def codegen(context, builder, signature, args):
        counter = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.IntType(64), []), "llvm.readcyclecounter")
        return builder.call(counter, [])
    return types.uint64(), codegen


@njit(inline="always")
def _lap(spent, slot, since):
    now = _cycles()
    spent[slot] += now - since
    return now


@njit(_nrt=False)
def _timed_step(robot, ground, scratch, pos, vel, params, spent):
    """``physics.step``, pass for pass, with the cycles of each added to ``spent``."""
    t = _cycles()
    ph.velocities(robot, vel, params)
    t = _lap(spent, 0, t)
    ph.start_contacts(robot, scratch, pos, vel, params)
    t = _lap(spent, 1, t)
    ph.start_springs(robot, scratch, pos, vel, params)
    t = _lap(spent, 2, t)
    ph.start_ropes(robot, scratch, pos, vel)
    t = _lap(spent, 3, t)
    ph.start_welds(robot, scratch, vel)
    t = _lap(spent, 4, t)
    for _ in range(params.velocity_iterations):
        ph.solve_springs(robot, scratch, vel)
        t = _lap(spent, 5, t)
        ph.solve_ropes(robot, scratch, vel)
        t = _lap(spent, 6, t)
        ph.solve_welds(robot, scratch, vel)
        t = _lap(spent, 7, t)
        ph.solve_contacts(robot, scratch, vel)
        t = _lap(spent, 8, t)
    ph.positions(robot, scratch, pos, vel, params)
    t = _lap(spent, 9, t)
    for _ in range(params.position_iterations):
        contacts_held = ph.fix_contacts(robot, scratch, pos)
        t = _lap(spent, 10, t)
        ropes_held = ph.fix_ropes(robot, pos)
        t = _lap(spent, 11, t)
        welds_held = ph.fix_welds(robot, pos, scratch.cos, scratch.sin)
        t = _lap(spent, 12, t)
        if contacts_held and ropes_held and welds_held:
            break
    ph.find_contacts(robot, ground, scratch, pos, params)
    _lap(spent, 13, t)


@njit
def _replay(system, ctrl, params, trace, actuations, b, spent):
    """Robot ``b``'s physics under ``actuations`` (n_steps + 1, V), timed pass by pass; its
    bodies' final state."""
    state = robot_state(system, b, params, robot_work(system, ctrl, params, b),
                        lidar_rays(params))
    start(b, system, params, trace, state)
    robot = state.robot
    scratch = state.scratch
    work = state.work
    for k in range(1, actuations.shape[0]):
        t = _cycles()
        for v in range(robot.n_voxels):
            work.actuation[v] = actuations[k - 1, v]
        ph.set_rest_lengths(robot.n_springs, robot.kind, robot.owner, work.actuation,
                            params.contract, params.expand, scratch.rest)
        _lap(spent, REST_LENGTHS, t)
        ph.turn(robot.n_points, work.body_pos, scratch.cos, scratch.sin)
        for _ in range(int(params.substeps)):
            _timed_step(robot, state.ground, scratch, work.body_pos, work.body_vel, params,
                        spent)
    ph.corner_state(robot, work.body_pos, work.body_vel, scratch.cos, scratch.sin, work.pos,
                    work.vel)
    return work.pos.copy()


@njit(_nrt=False)
def _timed_group_step(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes, first,
                      count, running, flags, spent):
    """``lanes._step`` for a group whose robots all run, part by part (``GROUP_PASSES``), the
    cycles of each added to ``spent``."""
    last = first + count
    t = _cycles()
    for b in range(first, last):
        state = _lane(system, ctrl, work, rays, b)
        ph.velocities(state.robot, state.work.body_vel, params)
        ph.start_contacts(state.robot, state.scratch, state.work.body_pos, state.work.body_vel,
                          params)
    t = _lap(spent, 0, t)
    for b in range(first, last):
        w = _lane(system, ctrl, work, rays, b).work
        jl.take(lanes, b - first, w.body_pos, w.body_vel, w.cos, w.sin)
    t = _lap(spent, 1, t)
    jl.start_joints(lanes, params)
    t = _lap(spent, 2, t)
    for _ in range(params.velocity_iterations):
        jl.solve_joints(lanes)
        t = _lap(spent, 3, t)
        for b in range(first, last):
            state = _lane(system, ctrl, work, rays, b)
            ph.solve_contacts(state.robot, state.scratch, lanes.vel[:, :, b - first])
        t = _lap(spent, 4, t)
    for b in range(first, last):
        jl.give_velocities(lanes, b - first, work.body_vel[b])
    t = _lap(spent, 1, t)
    for b in range(first, last):
        state = _lane(system, ctrl, work, rays, b)
        ph.positions(state.robot, state.scratch, state.work.body_pos, state.work.body_vel,
                     params)
        flags[b - first, F_DONE] = False
    t = _lap(spent, 5, t)
    fix_positions(system, ctrl, work, params, rays, joints, cos, sin, pos, first, running,
                  count, count, flags)
    t = _lap(spent, 6, t)
    for b in range(first, last):
        state = _lane(system, ctrl, work, rays, b)
        ph.find_contacts(state.robot, state.ground, state.scratch, state.work.body_pos, params)
    _lap(spent, 7, t)


@njit(_nrt=False)
def _replay_group_steps(system, ctrl, params, work, rays, actuations, first, count, joints,
                        cos, sin, pos, lanes, running, flags, spent):
    for k in range(1, actuations.shape[1]):
        t = _cycles()
        for b in range(first, first + count):
            state = _lane(system, ctrl, work, rays, b)
            for v in range(state.robot.n_voxels):
                state.work.actuation[v] = actuations[b, k - 1, v]
            before_physics(state.robot, state.work.actuation, params, lanes.rest[:, b - first])
            ph.turn(state.robot.n_points, state.work.body_pos, state.scratch.cos,
                    state.scratch.sin)
        _lap(spent, len(GROUP_PASSES) - 1, t)
        for _ in range(int(params.substeps)):
            _timed_group_step(system, ctrl, work, params, rays, joints, cos, sin, pos, lanes,
                              first, count, running, flags, spent)


@njit
def _replay_group(system, ctrl, params, trace, work, actuations, first, count, spent):
    """The physics of robots ``first .. first + count - 1`` as the CPU kernel's group, under
    ``actuations`` (B, n_steps + 1, V), timed part by part; their voxels' final corners (as
    :func:`_replay`'s)."""
    rays = lidar_rays(params)
    for b in range(first, first + count):
        start(b, system, params, trace, robot_state(system, b, params,
                                                    work_row(work, b, system, ctrl), rays))
    joints, cos, sin, pos = _merged(system, work, first, count)
    _replay_group_steps(system, ctrl, params, work, rays, actuations, first, count, joints, cos,
                        sin, pos, _lanes(system, work, first, count),
                        np.arange(first, first + count), np.zeros((count, 4), dtype=np.bool_),
                        spent)
    corners = np.full((count, work.pos.shape[1], 2), np.nan)
    for b in range(first, first + count):
        w = work_row(work, b, system, ctrl)
        state = robot_state(system, b, params, w, rays)
        ph.corner_state(state.robot, w.body_pos, w.body_vel, w.cos, w.sin, w.pos, w.vel)
        corners[b - first, :w.pos.shape[0]] = w.pos
    return corners


@njit
def _timed_episodes(system, ctrl, params, noise, seeds, n_steps, trace):
    """Each robot's whole episode, robot by robot as the CUDA kernel and the stepper run it
    (the CPU kernel advances groups of robots together: ``somite.tasks.lanes``): cycles."""
    rays = lidar_rays(params)
    t = _cycles()
    for b in range(seeds.shape[0]):
        state = robot_state(system, b, params, robot_work(system, ctrl, params, b), rays)
        episode(b, system, ctrl, params, noise, seeds[b], n_steps, trace, state)
    return _cycles() - t


@njit
def _now():
    return _cycles()


def _cycles_per_second() -> float:
    _now()
    t0, c0 = time.perf_counter(), _now()
    while time.perf_counter() - t0 < 0.2:
        pass
    return (_now() - c0) / (time.perf_counter() - t0)


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--shape", default="worm")
    parser.add_argument("--robots", type=int, default=24)
    parser.add_argument("--duration", type=float, default=10.0)
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    body = Body.build(args.shape)
    config = SimConfig(duration=args.duration)
    terrains = [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, args.robots)]
    graphs = [random_graph(body, 200, rng) for _ in range(args.robots)]
    system = compile_system([body] * args.robots, terrains)
    ctrl = compile_controllers(graphs, [body.shape.n_voxels] * args.robots)
    seeds = list(range(args.robots))
    params = pack_params(config)
    recorded = run(system, ctrl, config, seeds, record=True)

    numba.set_num_threads(1)
    per_second = _cycles_per_second()
    seeds_arr = np.asarray(seeds, dtype=np.uint64)
    episode_cycles = 0
    for _ in range(2):  # the first call compiles or loads
        trace = run(system, ctrl, config, seeds)  # a trace of the right shape
        episode_cycles = _timed_episodes(system, ctrl, params, noise_table(config),
                                         seeds_arr, config.n_steps, trace)
    spent = np.zeros(N_SLOTS, dtype=np.uint64)
    for first in (True, False):
        spent[:] = 0
        for b in range(args.robots):
            final = _replay(system, ctrl, params, trace, recorded.actuation[b], b, spent)
            if not first and not np.array_equal(
                    final, recorded.pos[b, -1, :final.shape[0]], equal_nan=True):
                raise SystemExit(f"robot {b}: the timed replay left physics.step's path: "
                                 "update benchmarks/passes.py to physics.step")
    steps = args.robots * config.n_steps
    kernel = np.inf
    for _ in range(3):
        t = time.perf_counter()
        run(system, ctrl, config, seeds)
        kernel = min(kernel, time.perf_counter() - t)
    grouped = np.zeros(len(GROUP_PASSES), dtype=np.uint64)
    first, count = groups(system, threads=1)
    for attempt in range(2):  # the first call compiles or loads
        grouped[:] = 0
        work = new_work(system, ctrl, params)
        for f, c in zip(first, count, strict=True):
            final = _replay_group(system, ctrl, params, trace, work, recorded.actuation, f, c,
                                  grouped)
            n_points = system.n_points[f]
            if attempt and not np.array_equal(final[:, :n_points],
                                              recorded.pos[f:f + c, -1, :n_points],
                                              equal_nan=True):
                raise SystemExit(f"group {f}: the timed replay left the CPU kernel's path: "
                                 "update benchmarks/passes.py to somite.tasks.lanes._step")
    us = 1e6 / per_second / steps
    names = (*PASSES, "rest lengths from the actuation")
    physics = float(spent.sum()) * us
    episode = float(episode_cycles) * us
    parts = {name: round(float(c) * us, 3) for name, c in zip(names, spent, strict=True)}
    parts["sensing, controller, diagnostics (the rest of the step)"] = round(
        episode - physics, 3)
    kernel_us = kernel * 1e6 / steps
    group_parts = {name: round(float(c) * us, 3)
                   for name, c in zip(GROUP_PASSES, grouped, strict=True)}
    group_parts["sensing, controller, diagnostics (the rest of the step)"] = round(
        kernel_us - float(grouped.sum()) * us, 3)
    return {
        "benchmark": "cost split of a control step, 1 thread",
        "shape": args.shape,
        "robots": args.robots,
        "control_steps": config.n_steps,
        "substeps": int(params.substeps),
        "control_step_us": round(episode, 3),
        "physics_us": round(physics, 3),
        "us_per_control_step": parts,
        "share": {name: round(v / episode, 4) for name, v in parts.items()},
        "cpu_kernel": {
            "groups": count.tolist(),
            "control_step_us": round(kernel_us, 3),
            "physics_us": round(float(grouped.sum()) * us, 3),
            "us_per_control_step": group_parts,
            "share": {name: round(v / kernel_us, 4) for name, v in group_parts.items()},
        },
    }


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
