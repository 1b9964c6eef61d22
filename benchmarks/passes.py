"""Where a control step's time goes, robot by robot: the physics passes one by one, and the rest
of the step.

The paper's workload (``somite bench``'s: random graph controllers of ~200 nodes + edges, each
robot on its own hilly terrain) is run once by the kernel, recording each step's actuation, and
timed whole on one thread. Then each robot's physics is replayed under the recorded actuations
by a copy of ``sim.physics.step`` with the CPU's cycle counter read between its passes; the
replay must end in the kernel's state bit for bit (checked: a copy that falls behind
``physics.step`` fails here). What the replay does not cover (sensing, the controller, the
diagnostics) is the episode's time less the physics'. Prints JSON: microseconds per robot and
control step, and each part's share; and, beside them, the CPU kernel's control step on the same
batch (``somite.tasks.lanes``: the joints' velocity passes of 8 robots at once as vector lanes,
the rest as here).

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
from somite.tasks.episode import episode, robot_state, robot_work, start
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
    us = 1e6 / per_second / steps
    names = (*PASSES, "rest lengths from the actuation")
    physics = float(spent.sum()) * us
    episode = float(episode_cycles) * us
    parts = {name: round(float(c) * us, 3) for name, c in zip(names, spent, strict=True)}
    parts["sensing, controller, diagnostics (the rest of the step)"] = round(
        episode - physics, 3)
    return {
        "benchmark": "cost split of a control step, 1 thread",
        "shape": args.shape,
        "robots": args.robots,
        "control_steps": config.n_steps,
        "substeps": int(params.substeps),
        "control_step_us": round(episode, 3),
        "cpu_kernel_control_step_us": round(kernel * 1e6 / steps, 3),
        "physics_us": round(physics, 3),
        "us_per_control_step": parts,
        "share": {name: round(v / episode, 4) for name, v in parts.items()},
    }


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
