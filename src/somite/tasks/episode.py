"""The batched episode kernel: where the simulator and the controllers meet.

``run_batch`` runs every robot's whole episode in one compiled loop, robots spread over the
cores with ``prange``. Per control step k = 1..n_steps (docs/original-system.md section 1.6): the
physics advances ``substeps`` steps under the actuation of step k - 1, the sensors read, the
controller computes the actuation for step k. Nothing is shared between robots but read-only
inputs, so a robot's outcome is the same whatever batch it runs in.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import prange

from .._jit import njit
from ..brain.kernels import graph_step
from ..brain.openloop import sine_actuation, table_actuation
from ..sim.config import CONTROL_HZ
from ..sim.physics import (
    advance,
    corner_state,
    ground_height,
    lowest_gap,
    segment_near,
    set_rest_lengths,
)
from ..sim.robot import ground_view, new_scratch, robot_view
from ..sim.sensors import angle_mode, lidar_rays, sense, update_histories, voxel_state

ZERO, SINE, TABLE, GRAPH = 0, 1, 2, 3
CONTROLLER_KINDS = {"zero": ZERO, "sine": SINE, "table": TABLE, "graph": GRAPH}

STATUS_OK, STATUS_NONFINITE = 0, 1

# Diagnostics of an episode, measured on every control step after the first SETTLE_STEPS (the
# robot is dropped at the start), as in the reference measurements of shared/reference.
D_MAX_TILT, D_FLIPPED, D_MAX_GAP, D_MAX_COM_HEIGHT, D_MAX_COM_SPEED, D_MIN_GAP = range(6)
N_DIAGNOSTICS = 6
SETTLE_STEPS = 120
"""2 s: the fall from the starting height is over."""


class Controllers(NamedTuple):
    """Controllers of a batch, padded (N nodes, E edges, L table rows)."""

    kind: np.ndarray  # (B,) int32 ZERO / SINE / TABLE / GRAPH
    sine: np.ndarray  # (B, 3) freq [Hz], amp, phase [rad per voxel column]
    table: np.ndarray  # (B, L, V) actuation rows
    table_period: np.ndarray  # (B,) int32 rows used
    n_nodes: np.ndarray  # (B,) int32
    node_kind: np.ndarray  # (B, N) int32 SENSOR / HIDDEN / ACTUATOR
    node_ref: np.ndarray  # (B, N) int32 reading index (sensor) or voxel index (actuator)
    n_edges: np.ndarray  # (B,) int32
    edge_src: np.ndarray  # (B, E) int32 node index
    edge_dst: np.ndarray  # (B, E) int32 node index
    edge_weight: np.ndarray  # (B, E)
    edge_bias: np.ndarray  # (B, E)


class Trace(NamedTuple):
    """What an episode leaves behind. ``pos`` .. ``contact`` have 0 rows unless recording."""

    com: np.ndarray  # (B, n_steps + 1, 2) centre of mass after each step [m]
    max_speed: np.ndarray  # (B,) largest speed of a voxel corner seen [m/s]
    min_area: np.ndarray  # (B,) smallest signed voxel area ratio seen (< 0: inverted)
    status: np.ndarray  # (B,) int32 STATUS_*
    non_finite: np.ndarray  # (B,) int32 control steps with a non-finite actuation or state
    diagnostics: np.ndarray  # (B, N_DIAGNOSTICS) D_*, measured after SETTLE_STEPS
    pos: np.ndarray  # (B or 0, n_steps + 1, P, 2) corner positions [m]
    actuation: np.ndarray  # (B or 0, n_steps + 1, V)
    readings: np.ndarray  # (B or 0, n_steps + 1, R) normalised, noisy
    contact: np.ndarray  # (B or 0, n_steps + 1, P) bool


def new_trace(n_robots: int, n_steps: int, system, record: bool) -> Trace:
    rows = n_robots if record else 0
    n_points = system.initial_pos.shape[1]
    n_voxels = system.voxel_corners.shape[1]
    n_readings = system.reading_code.shape[1]
    return Trace(
        com=np.full((n_robots, n_steps + 1, 2), np.nan),
        max_speed=np.zeros(n_robots),
        min_area=np.full(n_robots, np.inf),
        status=np.zeros(n_robots, dtype=np.int32),
        non_finite=np.zeros(n_robots, dtype=np.int32),
        diagnostics=np.zeros((n_robots, N_DIAGNOSTICS)),
        pos=np.zeros((rows, n_steps + 1, n_points, 2)),
        actuation=np.zeros((rows, n_steps + 1, n_voxels)),
        readings=np.zeros((rows, n_steps + 1, n_readings)),
        contact=np.zeros((rows, n_steps + 1, n_points), dtype=np.bool_),
    )


@njit(_nrt=False)
def _centre_of_mass(n_points, mass, pos):
    total = 0.0
    x = 0.0
    y = 0.0
    for p in range(n_points):
        total += mass[p]
        x += mass[p] * pos[p, 0]
        y += mass[p] * pos[p, 1]
    return x / total, y / total


@njit(_nrt=False)
def _column_tilt(n_voxels, voxel_x, x_lo, x_hi, voxels) -> float:
    """|angle| [deg] of the line from the leftmost column's centre to the rightmost's."""
    if x_lo == x_hi:
        return 0.0
    lx = ly = rx = ry = 0.0
    n_left = n_right = 0
    for v in range(n_voxels):
        if voxel_x[v] == x_lo:
            lx += voxels[v, 0]
            ly += voxels[v, 1]
            n_left += 1
        elif voxel_x[v] == x_hi:
            rx += voxels[v, 0]
            ry += voxels[v, 1]
            n_right += 1
    dx = rx / n_right - lx / n_left
    dy = ry / n_right - ly / n_left
    return abs(math.degrees(math.atan2(dy, dx)))


@njit(_nrt=False)
def _observe(k, robot, ground, n_points, mass, pos, vel, cos, sin, cx, cy, tilt, near, params,
             out):
    """Update the episode's diagnostics ``out`` (D_*) with control step ``k``; ``pos``,
    ``vel``: the bodies' state, ``cos``, ``sin`` their rotations; ``near``: a terrain segment
    near the robot."""
    if k <= SETTLE_STEPS:
        return
    gap = lowest_gap(robot, ground, pos, cos, sin, near)
    total = vx = vy = 0.0
    for p in range(n_points):
        total += mass[p]
        vx += mass[p] * vel[p, 0]
        vy += mass[p] * vel[p, 1]
    speed = math.sqrt(vx * vx + vy * vy) / total
    out[D_MAX_TILT] = max(out[D_MAX_TILT], tilt)
    if k > params.transient_steps and tilt > 90.0:
        out[D_FLIPPED] += 1.0
    out[D_MAX_GAP] = max(out[D_MAX_GAP], gap)
    out[D_MIN_GAP] = min(out[D_MIN_GAP], gap)
    height = cy - ground_height(ground.xs, ground.ys, ground.n, cx,
                                segment_near(ground.xs, ground.n, cx, near))
    out[D_MAX_COM_HEIGHT] = max(out[D_MAX_COM_HEIGHT], height)
    out[D_MAX_COM_SPEED] = max(out[D_MAX_COM_SPEED], speed)


@njit(_nrt=False)
def _record(b, step, n_points, n_voxels, n_readings, pos, contact, actuation, readings, trace):
    for p in range(n_points):
        trace.pos[b, step, p, 0] = pos[p, 0]
        trace.pos[b, step, p, 1] = pos[p, 1]
        trace.contact[b, step, p] = contact[p]
    for v in range(n_voxels):
        trace.actuation[b, step, v] = actuation[v]
    for r in range(n_readings):
        trace.readings[b, step, r] = readings[r]


@njit(_nrt=False)
def _control(b, k, ctrl, n_voxels, voxel_x, readings, h_prev, h_next, actuation, params):
    kind = ctrl.kind[b]
    if kind == SINE:
        sine_actuation(k / CONTROL_HZ, ctrl.sine[b, 0], ctrl.sine[b, 1], ctrl.sine[b, 2],
                       n_voxels, voxel_x, actuation)
    elif kind == TABLE:
        table_actuation(k, ctrl.table[b], ctrl.table_period[b], n_voxels, actuation)
    elif kind == GRAPH:
        # The two state buffers take turns: step k reads what step k - 1 wrote.
        old, new = (h_prev, h_next) if k % 2 == 1 else (h_next, h_prev)
        graph_step(ctrl.n_nodes[b], ctrl.node_kind[b], ctrl.node_ref[b], ctrl.n_edges[b],
                   ctrl.edge_src[b], ctrl.edge_dst[b], ctrl.edge_weight[b], ctrl.edge_bias[b],
                   old, new, readings, actuation, params.hidden_sigmoid)


@njit
def run_robot(b, system, ctrl, params, noise, seed, n_steps, trace):
    """Simulate robot ``b`` of the batch for ``n_steps`` control steps into ``trace``
    (``noise``: see :func:`~somite.sim.sensors.noise_table`)."""
    robot = robot_view(system, b, params)
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_nodes = ctrl.n_nodes[b]
    episode(b, system, ctrl, params, noise, seed, n_steps, trace, robot, ground_view(system, b),
            new_scratch(robot), np.empty((n_points, 3)), np.empty((n_points, 3)),
            np.empty((n_points, 2)), np.empty((n_points, 2)), np.empty((n_voxels, 6)),
            np.empty((n_voxels, int(params.touch_window))),
            np.empty((n_voxels, int(params.velocity_window), 2)),
            np.empty(system.n_readings[b]), np.empty(n_voxels), np.empty(n_nodes),
            np.empty(n_nodes), lidar_rays(params))


@njit(inline="always")
def episode(b, system, ctrl, params, noise, seed, n_steps, trace, robot, ground, scratch,
            body_pos, body_vel, pos, vel, voxels, touch_hist, vel_hist, readings, actuation,
            h_prev, h_next, rays):
    """:func:`run_robot` over supplied work arrays, which it initialises (a GPU thread cannot
    allocate): ``body_pos``, ``body_vel`` (P, 3) the corner bodies' state (centre of mass and
    angle, their rates), ``pos``, ``vel`` (P, 2) the voxel corners that they carry, ``voxels``
    (V, 6), ``touch_hist`` (V, touch window),
    ``vel_hist`` (V, velocity window, 2), ``readings`` (R,), ``actuation`` (V,), ``h_prev``,
    ``h_next`` (N,), ``rays`` :func:`~somite.sim.sensors.lidar_rays`; ``scratch`` from
    :func:`~somite.sim.robot.scratch_in`."""
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_readings = system.n_readings[b]
    mass = robot.mass
    voxel_x = system.voxel_x[b]
    recording = trace.pos.shape[0] > 0
    for p in range(n_points):
        body_pos[p, 0] = system.initial_pos[b, p, 0]
        body_pos[p, 1] = system.initial_pos[b, p, 1]
        body_pos[p, 2] = 0.0
        body_vel[p, 0] = body_vel[p, 1] = body_vel[p, 2] = 0.0
    corner_state(robot, body_pos, body_vel, scratch.cos, scratch.sin, pos, vel)
    for v in range(n_voxels):
        actuation[v] = 0.0
        for j in range(6):
            voxels[v, j] = 0.0
        for j in range(touch_hist.shape[1]):
            touch_hist[v, j] = 0.0
        for j in range(vel_hist.shape[1]):
            vel_hist[v, j, 0] = vel_hist[v, j, 1] = 0.0
    for r in range(n_readings):
        readings[r] = 0.0
    for n in range(h_prev.shape[0]):
        h_prev[n] = h_next[n] = 0.0
    substeps = int(params.substeps)
    angle = angle_mode(params)

    cx, cy = _centre_of_mass(n_points, mass, body_pos)
    trace.com[b, 0, 0] = cx
    trace.com[b, 0, 1] = cy
    if recording:
        _record(b, 0, n_points, n_voxels, n_readings, pos, scratch.contact, actuation, readings,
                trace)
    fastest = 0.0
    smallest = np.inf
    x_lo = x_hi = voxel_x[0]
    for v in range(n_voxels):
        x_lo = min(x_lo, voxel_x[v])
        x_hi = max(x_hi, voxel_x[v])
    diagnostics = trace.diagnostics[b]
    diagnostics[D_MAX_GAP] = -np.inf
    diagnostics[D_MIN_GAP] = np.inf
    non_finite = 0
    for k in range(1, n_steps + 1):
        set_rest_lengths(robot.n_springs, robot.kind, robot.owner, actuation, params.contract,
                         params.expand, scratch.rest)
        advance(robot, ground, scratch, body_pos, body_vel, params, substeps)
        corner_state(robot, body_pos, body_vel, scratch.cos, scratch.sin, pos, vel)
        cx, cy = _centre_of_mass(n_points, mass, body_pos)
        # The state's check, once per control step: any NaN or inf among the positions
        # reaches the centre of mass, any among the velocities their sum (max() would keep
        # the old value over a NaN).
        squares = 0.0
        for p in range(n_points):
            square = vel[p, 0] * vel[p, 0] + vel[p, 1] * vel[p, 1]
            squares += square
            fastest = max(fastest, square)
        if not (math.isfinite(cx) and math.isfinite(cy) and math.isfinite(squares)):
            trace.status[b] = STATUS_NONFINITE
            non_finite += 1
            break
        trace.com[b, k, 0] = cx
        trace.com[b, k, 1] = cy
        voxel_state(n_voxels, robot.corners, pos, vel, angle, voxels)
        for v in range(n_voxels):
            smallest = min(smallest, voxels[v, 4])
        near = scratch.segment[robot.n_points]
        tilt = _column_tilt(n_voxels, voxel_x, x_lo, x_hi, voxels)
        _observe(k, robot, ground, n_points, mass, body_pos, body_vel, scratch.cos, scratch.sin,
                 cx, cy, tilt, near, params, diagnostics)
        update_histories(k - 1, n_voxels, robot.corners, scratch.contact, voxels, touch_hist,
                         vel_hist, params)
        sense(k - 1, seed, n_readings, system.reading_code[b], system.reading_voxel[b], voxels,
              touch_hist, vel_hist, rays, ground.xs, ground.ys, ground.n, near, params, noise,
              readings)
        _control(b, k, ctrl, n_voxels, voxel_x, readings, h_prev, h_next, actuation, params)
        # The physics clamps actuation to [-1, 1] (a NaN acts as -1): counted, not hidden.
        for v in range(n_voxels):
            if not math.isfinite(actuation[v]):
                non_finite += 1
                break
        if recording:
            _record(b, k, n_points, n_voxels, n_readings, pos, scratch.contact, actuation,
                    readings, trace)
    trace.non_finite[b] = non_finite
    trace.max_speed[b] = math.sqrt(fastest)
    trace.min_area[b] = smallest


@njit(parallel=True)
def run_batch(system, ctrl, params, noise, seeds, n_steps, trace):
    """Run every robot of the batch; robots are spread over the available threads."""
    for b in prange(seeds.shape[0]):
        run_robot(b, system, ctrl, params, noise, seeds[b], n_steps, trace)
