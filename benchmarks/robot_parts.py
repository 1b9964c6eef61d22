"""What the parts of a control step that run robot by robot cost, and how far below that a
group's lanes could take them on physics 1 (issue 68, items 1 and 2).

A group of 8 robots (``somite bench``'s workload: random graphs of ~200 nodes + edges, each on
its own hilly terrain) is run to control step 300 by the stepper; then each part is called
alone on each robot's mid-episode state, ``--calls`` times, on one thread (thread CPU time, the
least of ``--repeats``), less the cost of taking the robot's views (timed alone). Beside the
parts, three floors that lanes cannot go under without changing a bit:

- **exp**: the graph's activations, the area and velocity sensors' normalisation and the
  noise's Gaussian draws call libm's ``exp`` and ``log`` (physics 1 keeps their rounding, so a
  vector ``exp`` is not allowed): how many calls a robot makes a step, times one call's cost;
- **contacts' clipping**: contact finding's separating-axis test and manifold, per pair of
  polygons that pass the bounding-box and above-the-segment tests (the rare, branchy case a
  lane solver keeps scalar), against the common path (polygons, boxes, the segment walk);
- **the controller in lanes**: the graph step for the group's 8 robots with per-lane padded
  edge lists (the lanes item 2 names), against 8 scalar graph steps; its outputs are compared
  bit for bit.

Prints JSON: microseconds per robot and control step.

    NUMBA_NUM_THREADS=1 python benchmarks/robot_parts.py [--shape worm] [--calls 500]
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numba
import numpy as np

from somite._jit import njit
from somite._math import tanh
from somite.bench import random_graph
from somite.brain.control import ControlIO, compile_controllers, control
from somite.brain.kernels import Graph, graph_step
from somite.brain.kinds import HIDDEN, RELAY, SENSOR
from somite.sim.body import Body
from somite.sim.config import pack_params, preset
from somite.sim.physics import (
    BLOCK_REACH,
    CLEAR_REACH,
    above_segment,
    block_normals,
    block_polygon,
    block_vertices,
    corner_state,
    deepest_axis,
    find_contacts,
    ground_polygon,
    ground_top,
    lowest_gap,
    manifold,
    segment_near,
)
from somite.sim.sensor_kinds import AREA, READING_KIND, VELOCITY
from somite.sim.sensors import (
    Sensing,
    angle_mode,
    lidar_rays,
    noise_table,
    sense,
    update_histories,
    voxel_state,
)
from somite.sim.system import compile_system
from somite.sim.terrain import hilly
from somite.tasks.episode import new_trace, robot_state, work_row
from somite.tasks.lanes import Batch
from somite.tasks.stepper import start_batch, step_batch
from somite.tasks.work import new_work

ROBOTS = 8
STEP = 300

PARTS = ("views alone", "corner_state", "voxel_state", "lowest_gap", "update_histories",
         "sense", "controller", "find_contacts", "contacts: tests, no clipping",
         "contacts: tests and clipping")


@njit
def _search(robot, ground, body, pos, clip):
    """find_contacts' tests without its table: with ``clip`` False its common path (the
    blocks' polygons, boxes and segment walks, the height and above-the-segment tests, the
    pairs' distances), returning how many pairs go on to clipping; with ``clip`` True those
    pairs clipped too (separating axes, manifold), returning the contact points."""
    xs, ys, n = ground.xs, ground.ys, ground.n
    one, two = body.polygon[0], body.polygon[1]
    found = 0
    top = ground_top(xs, ys, n, pos, robot.n_points, body.segment[robot.n_points])
    for p in range(robot.n_points):
        if pos[p, 1] - CLEAR_REACH > top:
            continue
        block_vertices(p, pos, body.cos, body.sin, two)
        lo_x = hi_x = two[0, 0]
        lo_y = two[0, 1]
        for j in range(1, 4):
            lo_x = min(lo_x, two[j, 0])
            hi_x = max(hi_x, two[j, 0])
            lo_y = min(lo_y, two[j, 1])
        i = segment_near(xs, n, lo_x, body.segment[p])
        while i < n - 1 and xs[i] < hi_x:
            if lo_y < max(ys[i], ys[i + 1]) and not above_segment(xs, ys, i, two):
                if not clip:
                    found += 1
                else:
                    block_normals(p, body.cos, body.sin, two)
                    ground_polygon(xs, ys, i, one)
                    overlap, nx, ny = deepest_axis(one, two)
                    if overlap > 0.0:
                        found += manifold(one, two, nx, ny, body.clipped)[0]
            i += 1
    for q in range(robot.n_pairs):
        a, b = robot.pair_ends[q, 0], robot.pair_ends[q, 1]
        dx = pos[b, 0] - pos[a, 0]
        dy = pos[b, 1] - pos[a, 1]
        if dx * dx + dy * dy >= 4.0 * BLOCK_REACH * BLOCK_REACH:
            continue
        if not clip:
            found += 1
            continue
        block_polygon(a, pos, body.cos, body.sin, one)
        block_polygon(b, pos, body.cos, body.sin, two)
        overlap, nx, ny = deepest_axis(one, two)
        if overlap > 0.0:
            found += manifold(one, two, nx, ny, body.clipped)[0]
    return found


@njit
def _part(which, calls, batch, step):
    system, ctrl, params = batch.system, batch.ctrl, batch.params
    acc = 0.0
    for _ in range(calls):
        for b in range(ROBOTS):
            state = robot_state(system, b, params, work_row(batch.work, b, system, ctrl, params),
                                batch.rays)
            robot, ground, work = state.robot, state.ground, state.work
            body, senses, brain = work.physics, work.senses, work.brain
            if which == 1:
                corner_state(robot, body.body_pos, body.body_vel, body.cos, body.sin, body.pos,
                             body.vel)
            elif which == 2:
                voxel_state(robot.n_voxels, robot.corners, body.pos, body.vel, angle_mode(params),
                            senses.voxels)
            elif which == 3:
                acc += lowest_gap(robot, ground, body.body_pos, body.cos, body.sin, body.segment)
            elif which == 4 or which == 5:
                sensing = Sensing(system.n_readings[b], system.reading_code[b],
                                  system.reading_voxel[b], senses.voxels, senses.touch_hist,
                                  senses.vel_hist, batch.rays)
                if which == 4:
                    update_histories(step - 1, robot.n_voxels, robot.corners, body.contact,
                                     sensing, params)
                else:
                    sense(step - 1, batch.seeds[b], sensing, ground, body.segment[robot.n_points],
                          params, batch.noise, senses.readings)
            elif which == 6:
                control(b, step, step / 60.0, ctrl,
                        ControlIO(robot.n_voxels, system.voxel_x[b], senses.readings,
                                  brain.h_prev, brain.h_next, brain.actuation), params)
            elif which == 7:
                find_contacts(robot, ground, body, body.body_pos, params)
                acc += body.counts[0]
            elif which == 8:
                acc += _search(robot, ground, body, body.body_pos, False)
            elif which == 9:
                acc += _search(robot, ground, body, body.body_pos, True)
    return acc


@njit
def _exp_calls(batch):
    """libm exp and log calls a robot makes in a control step (mean over the group)."""
    system, ctrl = batch.system, batch.ctrl
    calls = 0
    for b in range(ROBOTS):
        for n in range(ctrl.n_nodes[b]):
            if ctrl.node_kind[b, n] != RELAY:
                calls += 1
        n_readings = system.n_readings[b]
        for r in range(n_readings):
            kind = READING_KIND[system.reading_code[b, r]]
            if kind == AREA or kind == VELOCITY:
                calls += 1
        calls += (n_readings + 1) // 2  # the noise's log, one a pair of readings
    return calls / ROBOTS


@njit
def _exp_cost(xs, reps):
    total = 0.0
    for _ in range(reps):
        for i in range(xs.shape[0]):
            total += math.exp(xs[i])
    return total


@njit
def _graph_lanes(n_nodes, kind, ref, src, dst, weight, bias, h_prev, h_next, readings,
                 actuation, hidden_sigmoid):
    """A graph step for a group's robots at once: arrays (rows, lanes), edge lists padded with
    edges into the spare node row ``kind.shape[0] - 1`` (weight and bias 0), so every lane runs
    every row; each lane's additions are its own graph's in its own order."""
    width = kind.shape[1]
    for n in range(kind.shape[0]):
        for g in range(width):
            h_next[n, g] = 0.0
    for e in range(src.shape[0]):
        for g in range(width):
            h_next[dst[e, g], g] += h_prev[src[e, g], g] * weight[e, g] + bias[e, g]
    for n in range(kind.shape[0] - 1):
        for g in range(width):
            if n >= n_nodes[g]:
                continue
            k = kind[n, g]
            if k == SENSOR:
                h_next[n, g] = tanh(readings[ref[n, g], g])
            elif k == HIDDEN:
                h_next[n, g] = (1.0 / (1.0 + math.exp(-h_next[n, g])) if hidden_sigmoid
                                else tanh(h_next[n, g]))
            elif k != RELAY:
                h_next[n, g] = tanh(h_next[n, g])
                actuation[ref[n, g], g] = h_next[n, g]


@njit
def _graph_lanes_calls(calls, lanes, hidden_sigmoid):
    n_nodes, kind, ref, src, dst, weight, bias, h_prev, h_next, readings, actuation = lanes
    for _ in range(calls):
        _graph_lanes(n_nodes, kind, ref, src, dst, weight, bias, h_prev, h_next, readings,
                     actuation, hidden_sigmoid)


def _lanes_of(batch, readings):
    """The group's graphs as per-lane padded arrays, their state buffers holding each robot's."""
    ctrl = batch.ctrl
    n_nodes = ctrl.n_nodes[:ROBOTS].astype(np.int64)
    rows, edges = int(n_nodes.max()) + 1, int(ctrl.n_edges[:ROBOTS].max())
    kind = np.full((rows, ROBOTS), RELAY, dtype=np.int32)
    ref = np.zeros((rows, ROBOTS), dtype=np.int32)
    src = np.full((edges, ROBOTS), rows - 1, dtype=np.int32)
    dst = np.full((edges, ROBOTS), rows - 1, dtype=np.int32)
    weight = np.zeros((edges, ROBOTS))
    bias = np.zeros((edges, ROBOTS))
    for g in range(ROBOTS):
        n, e = int(n_nodes[g]), int(ctrl.n_edges[g])
        kind[:n, g], ref[:n, g] = ctrl.node_kind[g, :n], ctrl.node_ref[g, :n]
        src[:e, g], dst[:e, g] = ctrl.edge_src[g, :e], ctrl.edge_dst[g, :e]
        weight[:e, g], bias[:e, g] = ctrl.edge_weight[g, :e], ctrl.edge_bias[g, :e]
    h_prev = np.random.default_rng(1).uniform(-1, 1, (rows, ROBOTS))
    return (n_nodes, kind, ref, src, dst, weight, bias, h_prev, np.zeros((rows, ROBOTS)),
            readings, np.zeros((int(batch.system.n_voxels[:ROBOTS].max()), ROBOTS)))


@njit
def _graph_alone_calls(calls, batch, lanes, hidden_sigmoid):
    """The same graph steps robot by robot (the kernel's own ``graph_step``), on copies of
    the lanes' inputs; returns the outputs to compare."""
    ctrl = batch.ctrl
    n_nodes, kind, ref, src, dst, weight, bias, h_prev, h_next, readings, actuation = lanes
    prev = np.ascontiguousarray(h_prev.T)
    nxt = np.zeros_like(prev)
    reads = np.ascontiguousarray(readings.T)
    acts = np.zeros((actuation.shape[1], actuation.shape[0]))
    for _ in range(calls):
        for g in range(ROBOTS):
            graph = Graph(ctrl.n_nodes[g], ctrl.node_kind[g], ctrl.node_ref[g], ctrl.n_edges[g],
                          ctrl.edge_src[g], ctrl.edge_dst[g], ctrl.edge_weight[g],
                          ctrl.edge_bias[g])
            graph_step(graph, prev[g], nxt[g], reads[g], acts[g], hidden_sigmoid)
    return nxt, acts


def _least(fn, repeats):
    best = math.inf
    for _ in range(repeats):
        t = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t)
    return best


def measure(shape: str, calls: int, repeats: int) -> dict:
    rng = np.random.default_rng(0)
    body = Body.build(shape)
    graphs = [random_graph(body, 200, rng) for _ in range(ROBOTS)]
    system = compile_system([body] * ROBOTS, [hilly(1.0, 10.0, 30 + b) for b in range(ROBOTS)])
    ctrl = compile_controllers(graphs, [body.shape.n_voxels] * ROBOTS)
    config = preset("paper", duration=10.0)
    params, noise = pack_params(config), noise_table(config)
    seeds = np.arange(ROBOTS, dtype=np.uint64)
    trace = new_trace(ROBOTS, config.n_steps, system, False)
    batch = Batch(system, ctrl, params, noise, seeds, config.n_steps, trace,
                  new_work(system, ctrl, params, np.zeros), lidar_rays(params))
    start_batch(batch)
    for k in range(1, STEP):
        step_batch(k, batch, np.zeros((0, system.voxel_corners.shape[1])))
    per = calls * ROBOTS
    out = {"shape": shape, "robots": ROBOTS, "at step": STEP, "calls": calls,
           "unit": "us a robot and control step (thread CPU time, least of repeats)"}
    parts, counts = {}, {}
    for which, name in enumerate(PARTS):
        counts[name] = _part(which, 1, batch, STEP) / ROBOTS
        parts[name] = _least(lambda w=which: _part(w, calls, batch, STEP), repeats) * 1e6 / per
    views = parts.pop("views alone")
    counts.pop("views alone")
    out["parts"] = {name: round(t - views, 3) for name, t in parts.items()}
    out["views alone"] = round(views, 3)
    out["contact pairs clipped a step"] = counts["contacts: tests, no clipping"]
    out["contact points a step"] = counts["find_contacts"]

    xs = np.random.default_rng(2).uniform(-8.0, 0.0, 4096)
    _exp_cost(xs, 1)
    exp_ns = _least(lambda: _exp_cost(xs, 200), repeats) * 1e9 / (200 * xs.shape[0])
    n_exp = _exp_calls(batch)
    out["exp"] = {"calls a step": n_exp, "ns a call": round(exp_ns, 2),
                  "floor us": round(n_exp * exp_ns / 1e3, 3)}

    readings = np.random.default_rng(3).uniform(-1, 1, (int(system.n_readings.max()), ROBOTS))
    hidden_sigmoid = bool(params.hidden_sigmoid)
    lanes = _lanes_of(batch, readings)
    _graph_lanes_calls(1, lanes, hidden_sigmoid)
    nxt, acts = _graph_alone_calls(1, batch, lanes, hidden_sigmoid)
    lane_next, lane_actuation = lanes[8], lanes[10]
    same = all(
        np.array_equal(lane_next[:batch.ctrl.n_nodes[g], g], nxt[g, :batch.ctrl.n_nodes[g]])
        and np.array_equal(lane_actuation[:system.n_voxels[g], g], acts[g, :system.n_voxels[g]])
        for g in range(ROBOTS))
    lane_us = _least(lambda: _graph_lanes_calls(calls, lanes, hidden_sigmoid), repeats) * 1e6 / per
    alone_us = _least(lambda: _graph_alone_calls(calls, batch, lanes, hidden_sigmoid),
                      repeats) * 1e6 / per
    out["controller"] = {"nodes": float(batch.ctrl.n_nodes[:ROBOTS].mean()),
                         "edges": float(batch.ctrl.n_edges[:ROBOTS].mean()),
                         "robot by robot us": round(alone_us, 3), "in lanes us": round(lane_us, 3),
                         "gain": round(alone_us / lane_us, 2), "bit for bit": bool(same)}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--shape", action="append", choices=("worm", "biped"))
    parser.add_argument("--calls", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    numba.set_num_threads(1)
    shapes = args.shape or ["worm", "biped"]
    print(json.dumps([measure(s, args.calls, args.repeats) for s in shapes], indent=1))


if __name__ == "__main__":
    main()
