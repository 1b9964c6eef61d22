"""The layout question of issue 25, on the pass that costs most: one velocity pass over a worm's
216 springs (``sim.physics.solve_springs``), for 96 robots, three ways, on one thread:

- ``per_robot``: today's kernel, robot after robot (the real ``solve_springs``);
- ``interleaved``: W robots take each spring in turn (spring s of robot 1, ..., of robot W,
  then spring s + 1), each robot's arrays where they are now;
- ``lanes``: the same, with the state stored robots-innermost ((P, 3, W) and (S, 10, W)), so
  that the W robots' values of one spring are adjacent, as SIMD lanes want them;
- ``merged``: W robots as one robot of W x 216 springs, spring s of robot i its spring
  s * W + i, run by the real ``solve_springs`` (the CPU kernel's way before issue 25's lanes);
- ``vectorised``: the ``lanes`` layout, run by ``somite.sim.joint_lanes.solve_springs`` (every
  robot's values loaded before any is stored, so that LLVM's SLP vectoriser takes the W robots
  as vector lanes: what the CPU kernel does now, W = ``joint_lanes.LANES``).

Each way's result is checked bit for bit against ``per_robot`` (each robot's arithmetic is the
same, in its order). ``packed_multiplies`` counts vector multiply instructions (``vmulpd``) in the
compiled loop: whether LLVM vectorised across the lanes. Prints JSON: ns per robot and spring.

    python benchmarks/spring_lanes.py [--repeats 200]
"""

from __future__ import annotations

import argparse
import json
import time

import numba
import numpy as np

from somite._jit import njit, uncounted
from somite.sim import joint_lanes
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.physics import J_IMPULSE, J_MASS, solve_springs
from somite.sim.robot import robot_body, robot_view
from somite.sim.system import compile_system
from somite.sim.terrain import parse_terrain

ROBOTS = 96


@uncounted
def per_robot(robot, scratches, vel, passes):
    for r in range(vel.shape[0]):
        for _ in range(passes):
            solve_springs(robot, scratches[r], vel[r])


@njit(inline="always")
def _spring(s, a, b, w, v, inv_mass, inv_inertia):
    # sim.physics.solve_springs's arithmetic for one spring (checked against it).
    rax = w[s, 0]
    ray = w[s, 1]
    rbx = w[s, 2]
    rby = w[s, 3]
    vx = v[a, 0] - v[a, 2] * ray - (v[b, 0] - v[b, 2] * rby)
    vy = v[a, 1] + v[a, 2] * rax - (v[b, 1] + v[b, 2] * rbx)
    nx = w[s, 4]
    ny = w[s, 5]
    j = -w[s, 6] * (nx * vx + ny * vy + w[s, 8] + w[s, 7] * w[s, 9])
    w[s, 9] += j
    jx = nx * j
    jy = ny * j
    v[a, 0] += jx * inv_mass[a]
    v[a, 1] += jy * inv_mass[a]
    v[a, 2] += inv_inertia[a] * (rax * jy - ray * jx)
    v[b, 0] -= jx * inv_mass[b]
    v[b, 1] -= jy * inv_mass[b]
    v[b, 2] -= inv_inertia[b] * (rbx * jy - rby * jx)


@uncounted
def interleaved(ends, work, vel, inv_mass, inv_inertia, passes, width):
    for g in range(0, vel.shape[0], width):
        for _ in range(passes):
            for s in range(ends.shape[0]):
                a = ends[s, 0]
                b = ends[s, 1]
                for r in range(g, min(g + width, vel.shape[0])):
                    _spring(s, a, b, work[r], vel[r], inv_mass, inv_inertia)


@uncounted
def lanes(ends, work, vel, inv_mass, inv_inertia, passes):
    # work (G, S, 10, W), vel (G, P, 3, W)
    width = vel.shape[3]
    for g in range(vel.shape[0]):
        v = vel[g]
        w = work[g]
        for _ in range(passes):
            for s in range(ends.shape[0]):
                a = ends[s, 0]
                b = ends[s, 1]
                ima = inv_mass[a]
                imb = inv_mass[b]
                iia = inv_inertia[a]
                iib = inv_inertia[b]
                for k in range(width):
                    rax = w[s, 0, k]
                    ray = w[s, 1, k]
                    rbx = w[s, 2, k]
                    rby = w[s, 3, k]
                    vx = v[a, 0, k] - v[a, 2, k] * ray - (v[b, 0, k] - v[b, 2, k] * rby)
                    vy = v[a, 1, k] + v[a, 2, k] * rax - (v[b, 1, k] + v[b, 2, k] * rbx)
                    nx = w[s, 4, k]
                    ny = w[s, 5, k]
                    j = -w[s, 6, k] * (nx * vx + ny * vy + w[s, 8, k] + w[s, 7, k] * w[s, 9, k])
                    w[s, 9, k] += j
                    jx = nx * j
                    jy = ny * j
                    v[a, 0, k] += jx * ima
                    v[a, 1, k] += jy * ima
                    v[a, 2, k] += iia * (rax * jy - ray * jx)
                    v[b, 0, k] -= jx * imb
                    v[b, 1, k] -= jy * imb
                    v[b, 2, k] -= iib * (rbx * jy - rby * jx)


@uncounted
def vectorised(joints, work, vel, inv_mass, inv_inertia, passes):
    for g in range(vel.shape[0]):
        for _ in range(passes):
            joint_lanes.solve_springs(joints, work[g], vel[g], inv_mass, inv_inertia)


def _packed(kernel) -> int:
    return sum(asm.count("vmulpd") for asm in kernel.inspect_asm().values())


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    numba.set_num_threads(1)
    body = Body.build("worm")
    system = compile_system([body], [parse_terrain("flat")])
    robot = robot_view(system, 0, pack_params(SimConfig()))
    n_springs, n_points = robot.n_springs, robot.n_points
    rng = np.random.default_rng(0)
    work0 = rng.normal(0.0, 0.1, (ROBOTS, n_springs, 10))
    work0[:, :, J_MASS] = rng.uniform(0.05, 0.1, (ROBOTS, n_springs))
    work0[:, :, J_IMPULSE] = 0.0
    vel0 = rng.normal(0.0, 1.0, (ROBOTS, n_points, 3))
    ends = np.ascontiguousarray(robot.ends)
    # The lanes' kernel takes the springs in the group's order (joint_lanes.exact_order).
    joints = (ends, joint_lanes.exact_order(ends, n_points))

    def scratches(work):
        out = []
        for r in range(ROBOTS):
            scratch = robot_body(robot)
            scratch.spring[:] = work[r]
            out.append(scratch)
        return tuple(out)

    def timed(run, prepare):
        best = np.inf
        for _ in range(3):
            state = prepare()
            start = time.perf_counter()
            run(state, args.repeats)
            best = min(best, time.perf_counter() - start)
        return round(best * 1e9 / (ROBOTS * args.repeats * n_springs), 2)

    reference = vel0.copy()
    per_robot(robot, scratches(work0), reference, 3)
    result = {"benchmark": "one velocity pass over the worm's springs, 1 thread",
              "robots": ROBOTS, "springs": n_springs,
              "ns_per_robot_spring": {"per_robot": timed(
                  lambda st, n: per_robot(robot, st[0], st[1], n),
                  lambda: (scratches(work0), vel0.copy()))},
              "identical_to_per_robot": {}, "packed_multiplies": {}}
    figures = result["ns_per_robot_spring"]
    for width in (2, 4, 8, 16):
        def run_interleaved(st, n, width=width):
            interleaved(ends, st[0], st[1], robot.inv_mass, robot.inv_inertia, n, width)
        figures[f"interleaved_{width}"] = timed(run_interleaved,
                                                lambda: (work0.copy(), vel0.copy()))
        vel = vel0.copy()
        interleaved(ends, work0.copy(), vel, robot.inv_mass, robot.inv_inertia, 3, width)
        result["identical_to_per_robot"][f"interleaved_{width}"] = bool(
            np.array_equal(vel, reference))
    # Both kernels take the state robots innermost: work (G, S, 10, W), vel (G, P, 3, W).
    for name, kernel, widths in (("lanes", lanes, (4, 8, 16)),
                                 ("vectorised", vectorised, (joint_lanes.LANES,))):
        for width in widths:
            groups = ROBOTS // width

            def laned(a, columns, width=width, groups=groups):
                return np.ascontiguousarray(
                    a.reshape(groups, width, a.shape[1], columns).transpose(0, 2, 3, 1))

            which = joints if kernel is vectorised else ends

            def run_laned(st, n, kernel=kernel, which=which):
                kernel(which, st[0], st[1], robot.inv_mass, robot.inv_inertia, n)
            figures[f"{name}_{width}"] = timed(run_laned,
                                               lambda: (laned(work0, 10), laned(vel0, 3)))
            vel = laned(vel0, 3)
            kernel(which, laned(work0, 10), vel, robot.inv_mass, robot.inv_inertia, 3)
            back = vel.transpose(0, 3, 1, 2).reshape(ROBOTS, n_points, 3)
            result["identical_to_per_robot"][f"{name}_{width}"] = bool(
                np.array_equal(back, reference))
    for width in (2, 4, 8, 16):
        groups = ROBOTS // width
        ends_m = np.empty((width * n_springs, 2), dtype=robot.ends.dtype)
        for i in range(width):
            ends_m[i::width] = robot.ends + i * n_points
        merged = robot._replace(n_points=width * n_points, n_springs=width * n_springs,
                                ends=ends_m, inv_mass=np.tile(robot.inv_mass, width),
                                inv_inertia=np.tile(robot.inv_inertia, width))

        def merged_state(width=width, groups=groups, merged=merged):
            out = []
            for g in range(groups):
                scratch = robot_body(merged)
                scratch.spring[:] = work0[g * width:(g + 1) * width].transpose(1, 0, 2).reshape(
                    width * n_springs, 10)
                out.append(scratch)
            return tuple(out), vel0.copy().reshape(groups, width * n_points, 3)

        def run_merged(st, n, merged=merged):
            per_robot(merged, st[0], st[1], n)
        figures[f"merged_{width}"] = timed(run_merged, merged_state)
        st = merged_state()
        per_robot(merged, st[0], st[1], 3)
        result["identical_to_per_robot"][f"merged_{width}"] = bool(
            np.array_equal(st[1].reshape(ROBOTS, n_points, 3), reference))
    result["packed_multiplies"] = {"interleaved": _packed(interleaved),
                                   "lanes": _packed(lanes), "vectorised": _packed(vectorised)}
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
