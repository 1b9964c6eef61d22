"""The batched episode kernel: where the simulator and the controllers meet.

Per control step k = 1..n_steps (docs/original-system.md section 1.6): the
physics advances ``substeps`` steps under the actuation of step k - 1, the sensors read, the
controller computes the actuation for step k. Nothing is shared between robots but read-only
inputs, so a robot's outcome is the same whatever batch it runs in.

An episode is :func:`start`, :func:`control_step` for k = 1..n_steps and :func:`finish`, over one
robot's :class:`RobotState`; the CPU kernel (:mod:`somite.tasks.lanes`, which splits a control
step into :func:`before_physics`, the physics and :func:`after_physics` to advance a group of
robots together), the CUDA kernel (:mod:`somite.tasks.cuda_batch`) and the Python stepper
(:class:`somite.tasks.stepper.Episode`) all run these functions. The state's arrays
(:class:`~somite.tasks.work.Work`: the physics' :class:`~somite.sim.state.BodyState` and the
rest) are described once, in :data:`~somite.tasks.work.WORK_PARTS`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit, uncounted
from ..brain.control import ControlIO, Controllers, control
from ..sim.config import CONTROL_HZ, Params
from ..sim.physics import (
    advance,
    corner_state,
    ground_height,
    lowest_gap,
    segment_near,
    set_rest_lengths,
)
from ..sim.robot import Ground, Robot, fill_robot, filled_robot, ground_view, reset_body
from ..sim.sensors import Sensing, angle_mode, sense, update_histories, voxel_state
from ..sim.system import System
from .work import T_FASTEST, T_NON_FINITE, T_SMALLEST, T_X_HI, T_X_LO, Work, work_counts
from .work_views import new_robot_work, work_views

STATUS_OK, STATUS_NONFINITE = 0, 1

# Diagnostics of an episode, measured on every control step after the first SETTLE_STEPS (the
# robot is dropped at the start), as in the reference measurements of shared/reference.
D_MAX_TILT, D_FLIPPED, D_MAX_GAP, D_MAX_COM_HEIGHT, D_MAX_COM_SPEED, D_MIN_GAP = range(6)
N_DIAGNOSTICS = 6
SETTLE_STEPS = 120
"""2 s: the fall from the starting height is over."""

class Batch(NamedTuple):
    """A batch's inputs, and what its episodes write into (``trace``, the rows of ``work``):
    what every kernel over robots of the batch reads."""

    system: System
    ctrl: Controllers
    params: Params
    noise: np.ndarray  # noise_table(config)
    seeds: np.ndarray  # (B,) uint64: each robot's sensor noise
    n_steps: int
    trace: Trace
    work: Work
    rays: np.ndarray  # lidar_rays(params)


class RobotState(NamedTuple):
    """Everything one robot's episode reads and writes besides the batch's inputs and trace:
    the robot's build and terrain, its :class:`~somite.tasks.work.Work` (the physics' part is
    ``work.physics``)."""

    robot: Robot
    ground: Ground
    work: Work
    rays: np.ndarray  # (5, 2) lidar_rays(params)


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


@uncounted
def _centre_of_mass(n_points, mass, pos):
    total = 0.0
    x = 0.0
    y = 0.0
    for p in range(n_points):
        total += mass[p]
        x += mass[p] * pos[p, 0]
        y += mass[p] * pos[p, 1]
    return x / total, y / total


@uncounted
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


@uncounted
def _observe(k, robot, ground, body, at, params, out):
    """Update the episode's diagnostics ``out`` (D_*) with control step ``k``; ``body``: the
    robot's :class:`~somite.sim.state.BodyState`; ``at``: its centre of mass (x, y), tilt [deg]
    and a terrain segment near it."""
    if k <= SETTLE_STEPS:
        return
    cx, cy, tilt, near = at
    mass, vel = robot.mass, body.body_vel
    gap = lowest_gap(robot, ground, body.body_pos, body.cos, body.sin, body.segment)
    total = vx = vy = 0.0
    for p in range(robot.n_points):
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


@uncounted
def _record(b, step, state, trace):
    """Robot ``b``'s corners, contacts, actuation and readings into ``trace`` at ``step``."""
    pos, contact = state.work.physics.pos, state.work.physics.contact
    actuation, readings = state.work.brain.actuation, state.work.senses.readings
    for p in range(state.robot.n_points):
        trace.pos[b, step, p, 0] = pos[p, 0]
        trace.pos[b, step, p, 1] = pos[p, 1]
        trace.contact[b, step, p] = contact[p]
    for v in range(state.robot.n_voxels):
        trace.actuation[b, step, v] = actuation[v]
    for r in range(readings.shape[0]):
        trace.readings[b, step, r] = readings[r]


@njit
def robot_work(system, ctrl, params, b) -> Work:
    """Robot ``b``'s :class:`~somite.tasks.work.Work`, allocated to its own sizes."""
    return new_robot_work(work_counts(system, ctrl, params, b))


@njit
def work_row(work, b, system, ctrl, params) -> Work:
    """Robot ``b``'s :class:`~somite.tasks.work.Work` as views of a batch's
    (:func:`~somite.tasks.work.new_work`), trimmed to its own sizes: a GPU thread cannot
    allocate, the stepper keeps the state."""
    return work_views(work, b, work_counts(system, ctrl, params, b))


@uncounted
def uncounted_work_row(work, b, system, ctrl, params) -> Work:
    """:func:`work_row` for kernels compiled without reference counting (``_jit.uncounted``), and
    only for them: the compiled :func:`work_row` returns views that it has counted, which such
    a kernel never releases (each batch's arrays then stayed in memory: 11 MB a batch of 96
    worms); these views are counted by no one, as the kernel's own are not."""
    return work_views(work, b, work_counts(system, ctrl, params, b))


@njit
def robot_state(system, b, params, work, rays) -> RobotState:
    """Robot ``b``'s :class:`RobotState` over ``work`` (its :func:`robot_work` or
    :func:`work_row`) and ``rays`` (:func:`~somite.sim.sensors.lidar_rays`)."""
    fill_robot(system, b, params, work.physics.inv_mass, work.physics.inv_inertia)
    return filled_state(system, b, work, rays)


@njit(inline="always")
def filled_state(system, b, work, rays) -> RobotState:
    """:func:`robot_state` over a ``work`` that it has filled before."""
    robot = filled_robot(system, b, work.physics.inv_mass, work.physics.inv_inertia)
    return RobotState(robot, ground_view(system, b), work, rays)


@njit
def _x_extent(n_voxels, voxel_x):
    x_lo = x_hi = voxel_x[0]
    for v in range(n_voxels):
        x_lo = min(x_lo, voxel_x[v])
        x_hi = max(x_hi, voxel_x[v])
    return x_lo, x_hi


@njit
def start(b, system, params, trace, state) -> None:
    """Set robot ``b``'s ``state`` to the start of its episode and record step 0."""
    robot = state.robot
    work = state.work
    body = work.physics
    reset_body(robot, body)
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_readings = system.n_readings[b]
    body_pos = body.body_pos
    body_vel = body.body_vel
    touch_hist = work.senses.touch_hist
    vel_hist = work.senses.vel_hist
    h_prev = work.brain.h_prev
    h_next = work.brain.h_next
    for p in range(n_points):
        body_pos[p, 0] = system.initial_pos[b, p, 0]
        body_pos[p, 1] = system.initial_pos[b, p, 1]
        body_pos[p, 2] = 0.0
        body_vel[p, 0] = body_vel[p, 1] = body_vel[p, 2] = 0.0
    corner_state(robot, body_pos, body_vel, body.cos, body.sin, body.pos, body.vel)
    for v in range(n_voxels):
        work.brain.actuation[v] = 0.0
        for j in range(6):
            work.senses.voxels[v, j] = 0.0
        for j in range(touch_hist.shape[1]):
            touch_hist[v, j] = 0.0
        for j in range(vel_hist.shape[1]):
            vel_hist[v, j, 0] = vel_hist[v, j, 1] = 0.0
    for r in range(n_readings):
        work.senses.readings[r] = 0.0
    for n in range(h_prev.shape[0]):
        h_prev[n] = h_next[n] = 0.0
    cx, cy = _centre_of_mass(n_points, robot.mass, body_pos)
    trace.status[b] = STATUS_OK
    trace.com[b, 0, 0] = cx
    trace.com[b, 0, 1] = cy
    if trace.pos.shape[0] > 0:
        _record(b, 0, state, trace)
    work.tally[T_FASTEST] = 0.0
    work.tally[T_SMALLEST] = np.inf
    work.tally[T_NON_FINITE] = 0.0
    work.tally[T_X_LO], work.tally[T_X_HI] = _x_extent(n_voxels, system.voxel_x[b])
    diagnostics = trace.diagnostics[b]
    for d in range(N_DIAGNOSTICS):
        diagnostics[d] = 0.0
    diagnostics[D_MAX_GAP] = -np.inf
    diagnostics[D_MIN_GAP] = np.inf


# Inlined into its loops: a call per control step would pass the whole RobotState (some 50
# arrays) and count references to each (measured: 6% of the kernel's time).
@njit(inline="always")
def control_step(k, b, batch, state) -> bool:
    """Control step ``k`` (1..n_steps) of robot ``b`` of ``batch``: False when its state went
    non-finite, which ends its episode (``trace.status``). The physics under the actuation in force
    (:func:`before_physics`, ``advance``), then :func:`after_physics`; the CPU kernel
    (:mod:`somite.tasks.lanes`) runs the three parts over a group of robots at once."""
    params = batch.params
    body = state.work.physics
    before_physics(state.robot, state.work.brain.actuation, params, body.rest)
    advance(state.robot, state.ground, body, params, int(params.substeps))
    return after_physics(k, b, batch, state)


@njit(inline="always")
def before_physics(robot, actuation, params, rest) -> None:
    """The springs' rest lengths ``rest`` under the actuation in force."""
    set_rest_lengths(robot.n_springs, robot.kind, robot.owner, actuation, params.contract,
                     params.expand, rest)


@njit(inline="always")
def after_physics(k, b, batch, state) -> bool:
    """What control step ``k`` does after its physics: check the state, observe, sense,
    control, record (:func:`control_step`'s return value)."""
    system, ctrl, params, trace = batch.system, batch.ctrl, batch.params, batch.trace
    noise, seed = batch.noise, batch.seeds[b]
    robot = state.robot
    ground = state.ground
    work = state.work
    body = work.physics
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_readings = system.n_readings[b]
    mass = robot.mass
    voxel_x = system.voxel_x[b]
    body_pos = body.body_pos
    body_vel = body.body_vel
    pos = body.pos
    vel = body.vel
    voxels = work.senses.voxels
    readings = work.senses.readings
    actuation = work.brain.actuation
    tally = work.tally
    corner_state(robot, body_pos, body_vel, body.cos, body.sin, pos, vel)
    cx, cy = _centre_of_mass(n_points, mass, body_pos)
    # The state's check, once per control step: any NaN or inf among the positions reaches the
    # centre of mass, any among the velocities their sum (max() would keep the old value over
    # a NaN).
    squares = 0.0
    fastest = tally[T_FASTEST]
    for p in range(n_points):
        square = vel[p, 0] * vel[p, 0] + vel[p, 1] * vel[p, 1]
        squares += square
        fastest = max(fastest, square)
    tally[T_FASTEST] = fastest
    if not (math.isfinite(cx) and math.isfinite(cy) and math.isfinite(squares)):
        trace.status[b] = STATUS_NONFINITE
        tally[T_NON_FINITE] += 1.0
        return False
    trace.com[b, k, 0] = cx
    trace.com[b, k, 1] = cy
    voxel_state(n_voxels, robot.corners, pos, vel, angle_mode(params), voxels)
    smallest = tally[T_SMALLEST]
    for v in range(n_voxels):
        smallest = min(smallest, voxels[v, 4])
    tally[T_SMALLEST] = smallest
    near = body.segment[robot.n_points]
    tilt = _column_tilt(n_voxels, voxel_x, tally[T_X_LO], tally[T_X_HI], voxels)
    _observe(k, robot, ground, body, (cx, cy, tilt, near), params, trace.diagnostics[b])
    senses = work.senses
    sensing = Sensing(n_readings, system.reading_code[b], system.reading_voxel[b], voxels,
                      senses.touch_hist, senses.vel_hist, state.rays)
    update_histories(k - 1, n_voxels, robot.corners, body.contact, sensing, params)
    sense(k - 1, seed, sensing, ground, near, params, noise, readings)
    control(b, k, k / CONTROL_HZ, ctrl, ControlIO(n_voxels, voxel_x, readings, work.brain.h_prev,
                                                  work.brain.h_next, actuation), params)
    # The physics clamps actuation to [-1, 1] (a NaN acts as -1): counted, not hidden.
    for v in range(n_voxels):
        if not math.isfinite(actuation[v]):
            tally[T_NON_FINITE] += 1.0
            break
    if trace.pos.shape[0] > 0:
        _record(b, k, state, trace)
    return True


@njit
def finish(b, trace, state) -> None:
    """Write what robot ``b``'s episode accumulated so far to ``trace``."""
    tally = state.work.tally
    trace.non_finite[b] = int(tally[T_NON_FINITE])
    trace.max_speed[b] = math.sqrt(tally[T_FASTEST])
    trace.min_area[b] = tally[T_SMALLEST]


@njit(inline="always")
def episode(b, batch, state) -> None:
    """Robot ``b``'s whole episode over ``state`` (:func:`robot_state`), into ``batch.trace``."""
    start(b, batch.system, batch.params, batch.trace, state)
    for k in range(1, batch.n_steps + 1):
        if not control_step(k, b, batch, state):
            break
    finish(b, batch.trace, state)
