"""The batched episode kernel: where the simulator and the controllers meet.

``run_batch`` runs every robot's whole episode in one compiled loop, robots spread over the
cores with ``prange``. Per control step k = 1..n_steps (original-system.md section 1.6): the
physics advances ``substeps`` substeps under the actuation of step k - 1, the sensors read, the
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
from ..sim.config import (
    CONTROL_HZ,
    P_HIDDEN_SIGMOID,
    P_MIN_LENGTH,
    P_SUBSTEPS,
    P_TOUCH_WINDOW,
    P_VELOCITY_WINDOW,
)
from ..sim.physics import enforce_min_lengths, set_rest_lengths, substep
from ..sim.sensors import angle_mode, lidar_rays, sense, update_histories, voxel_state

ZERO, SINE, TABLE, GRAPH = 0, 1, 2, 3
CONTROLLER_KINDS = {"zero": ZERO, "sine": SINE, "table": TABLE, "graph": GRAPH}

STATUS_OK, STATUS_NONFINITE = 0, 1


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
    max_speed: np.ndarray  # (B,) largest corner speed seen [m/s]
    min_area: np.ndarray  # (B,) smallest signed voxel area ratio seen (< 0: inverted)
    status: np.ndarray  # (B,) int32 STATUS_*
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
        pos=np.zeros((rows, n_steps + 1, n_points, 2)),
        actuation=np.zeros((rows, n_steps + 1, n_voxels)),
        readings=np.zeros((rows, n_steps + 1, n_readings)),
        contact=np.zeros((rows, n_steps + 1, n_points), dtype=np.bool_),
    )


@njit
def _centre_of_mass(n_points, mass, pos):
    total = 0.0
    x = 0.0
    y = 0.0
    for p in range(n_points):
        total += mass[p]
        x += mass[p] * pos[p, 0]
        y += mass[p] * pos[p, 1]
    return x / total, y / total


@njit
def _record(b, step, n_points, n_voxels, n_readings, pos, contact, actuation, readings, trace):
    for p in range(n_points):
        trace.pos[b, step, p, 0] = pos[p, 0]
        trace.pos[b, step, p, 1] = pos[p, 1]
        trace.contact[b, step, p] = contact[p]
    for v in range(n_voxels):
        trace.actuation[b, step, v] = actuation[v]
    for r in range(n_readings):
        trace.readings[b, step, r] = readings[r]


@njit
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
                   old, new, readings, actuation, params[P_HIDDEN_SIGMOID] == 1.0)


@njit
def run_robot(b, system, ctrl, params, noise, seed, n_steps, trace):
    """Simulate robot ``b`` of the batch for ``n_steps`` control steps into ``trace``
    (``noise``: see :func:`~somite.sim.sensors.noise_table`)."""
    n_points = system.n_points[b]
    n_springs = system.n_springs[b]
    n_voxels = system.n_voxels[b]
    n_boundary = system.n_boundary[b]
    n_readings = system.n_readings[b]
    t = system.terrain_of[b]
    xs = system.terrain_x[t]
    ys = system.terrain_y[t]
    n_terrain = system.terrain_n[t]
    nxs = system.terrain_nx[t]
    nys = system.terrain_ny[t]
    mass = system.mass[b]
    rest0 = system.spring_rest[b]
    corners = system.voxel_corners[b]
    ends = system.spring_ends[b]
    boundary = system.boundary[b]
    recording = trace.pos.shape[0] > 0

    pos = system.initial_pos[b, :n_points].copy()
    vel = np.zeros((n_points, 2))
    force = np.zeros((n_points, 2))
    work = (np.zeros(n_springs), np.zeros(n_springs), np.zeros(n_springs),
            np.zeros(n_springs), np.zeros(n_springs), np.zeros(n_springs))
    contact = np.zeros(n_points, dtype=np.bool_)
    segment = np.zeros(n_points + 1, dtype=np.int64)
    rest = rest0[:n_springs].copy()
    inv_mass = 1.0 / mass[:n_points]
    min_length = rest0[:n_springs] * params[P_MIN_LENGTH]
    strength = np.ones(n_springs)
    for s in range(n_springs):
        if system.spring_owners[b, s, 1] >= 0:
            strength[s] = 2.0
    voxels = np.zeros((n_voxels, 6))
    touch_hist = np.zeros((n_voxels, int(params[P_TOUCH_WINDOW])))
    vel_hist = np.zeros((n_voxels, int(params[P_VELOCITY_WINDOW]), 2))
    readings = np.zeros(n_readings)
    actuation = np.zeros(n_voxels)
    factor = np.ones(n_voxels)
    n_nodes = ctrl.n_nodes[b]
    h_prev = np.zeros(n_nodes)
    h_next = np.zeros(n_nodes)
    substeps = int(params[P_SUBSTEPS])
    rays = lidar_rays(params)
    angle = angle_mode(params)

    cx, cy = _centre_of_mass(n_points, mass, pos)
    trace.com[b, 0, 0] = cx
    trace.com[b, 0, 1] = cy
    if recording:
        _record(b, 0, n_points, n_voxels, n_readings, pos, contact, actuation, readings, trace)
    fastest = 0.0
    smallest = np.inf
    for k in range(1, n_steps + 1):
        set_rest_lengths(n_voxels, n_springs, system.spring_owners[b], rest0, actuation, params,
                         factor, rest)
        for _ in range(substeps):
            substep(n_points, n_springs, n_boundary, ends, strength, rest, min_length, mass,
                    inv_mass, boundary, pos, vel, force, work, contact, segment, xs, ys, nxs,
                    nys, n_terrain, params)
        enforce_min_lengths(n_springs, ends, min_length, inv_mass, pos, vel)
        cx, cy = _centre_of_mass(n_points, mass, pos)
        for p in range(n_points):
            fastest = max(fastest, vel[p, 0] * vel[p, 0] + vel[p, 1] * vel[p, 1])
        if not (math.isfinite(cx) and math.isfinite(cy) and math.isfinite(fastest)):
            trace.status[b] = STATUS_NONFINITE
            break
        trace.com[b, k, 0] = cx
        trace.com[b, k, 1] = cy
        voxel_state(n_voxels, corners, pos, vel, angle, voxels)
        for v in range(n_voxels):
            smallest = min(smallest, voxels[v, 4])
        update_histories(k - 1, n_voxels, corners, contact, voxels, touch_hist, vel_hist, params)
        sense(k - 1, seed, n_readings, system.reading_code[b], system.reading_voxel[b], voxels,
              touch_hist, vel_hist, rays, xs, ys, n_terrain, segment[n_points], params, noise,
              readings)
        _control(b, k, ctrl, n_voxels, system.voxel_x[b], readings, h_prev, h_next, actuation,
                 params)
        if recording:
            _record(b, k, n_points, n_voxels, n_readings, pos, contact, actuation, readings, trace)
    trace.max_speed[b] = math.sqrt(fastest)
    trace.min_area[b] = smallest


@njit(parallel=True)
def run_batch(system, ctrl, params, noise, seeds, n_steps, trace):
    """Run every robot of the batch; robots are spread over the available threads."""
    for b in prange(seeds.shape[0]):
        run_robot(b, system, ctrl, params, noise, seeds[b], n_steps, trace)
