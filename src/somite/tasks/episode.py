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
(:class:`Work`) are described once, in :data:`WORK_PARTS`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._jit import njit, uncounted
from ..brain.control import ControlIO, Controllers, control
from ..sim.config import CONTROL_HZ, Params
from ..sim.physics import (
    N_CONTACT_COLUMNS,
    N_ROPE_COLUMNS,
    N_SPRING_COLUMNS,
    N_WELD_COLUMNS,
    advance,
    corner_state,
    ground_height,
    lowest_gap,
    segment_near,
    set_rest_lengths,
)
from ..sim.robot import (
    Ground,
    Robot,
    Scratch,
    contact_capacity,
    fill_robot,
    filled_robot,
    ground_view,
    reset_scratch,
)
from ..sim.sensors import Sensing, angle_mode, sense, update_histories, voxel_state
from ..sim.system import System

STATUS_OK, STATUS_NONFINITE = 0, 1

# Diagnostics of an episode, measured on every control step after the first SETTLE_STEPS (the
# robot is dropped at the start), as in the reference measurements of shared/reference.
D_MAX_TILT, D_FLIPPED, D_MAX_GAP, D_MAX_COM_HEIGHT, D_MAX_COM_SPEED, D_MIN_GAP = range(6)
N_DIAGNOSTICS = 6
SETTLE_STEPS = 120
"""2 s: the fall from the starting height is over."""

# Slots of Work.tally: what an episode accumulates until finish() writes it to the trace, and
# the body's extent along x in voxel columns (fixed; start() finds it once).
T_FASTEST, T_SMALLEST, T_NON_FINITE, T_X_LO, T_X_HI = range(5)
N_TALLY = 5

WORK_PARTS = {
    "blocks": {  # the corner bodies and the voxel corners they carry
        "inv_mass": (("P",), np.float64),
        "inv_inertia": (("P",), np.float64),
        "cos": (("P",), np.float64),
        "sin": (("P",), np.float64),
        "body_pos": (("P", 3), np.float64),
        "body_vel": (("P", 3), np.float64),
        "pos": (("P", 2), np.float64),
        "vel": (("P", 2), np.float64),
    },
    "joints": {  # the springs' rest lengths, the joints' rows of the solver
        "rest": (("S",), np.float64),
        "spring": (("S", N_SPRING_COLUMNS), np.float64),
        "rope": (("Y", N_ROPE_COLUMNS), np.float64),
        "weld": (("W", N_WELD_COLUMNS), np.float64),
    },
    "collisions": {  # contact rows (this step's, last step's), the search's scratch
        "contacts": (("C", N_CONTACT_COLUMNS), np.float64),
        "previous": (("C", N_CONTACT_COLUMNS), np.float64),
        "counts": ((2,), np.int64),
        "polygon": ((2, 4, 4), np.float64),
        "clipped": ((2, 4), np.float64),
        "contact": (("P",), np.bool_),
        "segment": (("P+1",), np.int64),
    },
    "senses": {  # the voxels' state, the sensors' windows, the readings
        "voxels": (("V", 6), np.float64),
        "touch_hist": (("V", "touch"), np.float64),
        "vel_hist": (("V", "velocity", 2), np.float64),
        "readings": (("R",), np.float64),
    },
    "brain": {  # the actuation in force, the controller's two node buffers
        "actuation": (("V",), np.float64),
        "h_prev": (("N",), np.float64),
        "h_next": (("N",), np.float64),
    },
    "tally": {"tally": ((N_TALLY,), np.float64)},
}
"""The per-robot arrays of an episode, by what they hold: part -> name -> (shape, dtype). A
shape's names are one robot's counts (:func:`work_sizes`): P blocks, S springs, Y ropes, W
welds, C contact rows (:func:`~somite.sim.robot.contact_capacity`), V voxels, R readings, N
controller nodes, the sensors' ``touch`` and ``velocity`` windows. ``body_pos``, ``body_vel``
are the corner bodies' state (centre of mass and angle, their rates), ``pos``, ``vel`` the
voxel corners that they carry; ``tally`` holds T_*. The physics reads its
:class:`~somite.sim.robot.Scratch` from ``blocks``, ``joints`` and ``collisions``.
:func:`robot_work` and :func:`work_row` follow this table (tested)."""

WORK_FIELDS = {name: spec for fields in WORK_PARTS.values() for name, spec in fields.items()}
"""Every field of :data:`WORK_PARTS`, by name."""


def _part(name: str, fields: dict) -> type:
    part = NamedTuple(name, [(field, np.ndarray) for field in fields])
    part.__doc__ = f"One robot's {name.lower()} arrays of :data:`WORK_PARTS` (or a batch's)."
    return part


Blocks = _part("Blocks", WORK_PARTS["blocks"])
Joints = _part("Joints", WORK_PARTS["joints"])
Collisions = _part("Collisions", WORK_PARTS["collisions"])
Senses = _part("Senses", WORK_PARTS["senses"])
BrainState = _part("BrainState", WORK_PARTS["brain"])


class Work(NamedTuple):
    """One robot's arrays of :data:`WORK_PARTS` (or a batch's, robot axis first), by part."""

    blocks: Blocks
    joints: Joints
    collisions: Collisions
    senses: Senses
    brain: BrainState
    tally: np.ndarray


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
    """Everything one robot's episode reads and writes besides the batch's inputs and trace."""

    robot: Robot
    ground: Ground
    scratch: Scratch  # views of work's fields
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


def work_sizes(system, ctrl: Controllers, params, b: int | None = None) -> dict:
    """The counts that :data:`WORK_FIELDS` names: robot ``b``'s, or the batch's padded ones."""
    if b is None:
        p = system.initial_pos.shape[1]
        sizes = {"P": p, "S": system.spring_ends.shape[1], "Y": system.rope_ends.shape[1],
                 "W": system.weld_ends.shape[1],
                 "C": contact_capacity(p, system.pair_ends.shape[1]),
                 "V": system.voxel_corners.shape[1], "R": system.reading_code.shape[1],
                 # One node at least: a batch without graphs still has the field.
                 "N": max(1, ctrl.node_kind.shape[1])}
    else:
        p = int(system.n_points[b])
        sizes = {"P": p, "S": int(system.n_springs[b]), "Y": int(system.n_ropes[b]),
                 "W": int(system.n_welds[b]), "C": contact_capacity(p, int(system.n_pairs[b])),
                 "V": int(system.n_voxels[b]), "R": int(system.n_readings[b]),
                 "N": int(ctrl.n_nodes[b])}
    return {**sizes, "P+1": sizes["P"] + 1, "touch": int(params.touch_window),
            "velocity": int(params.velocity_window)}


def work_shape(name: str, sizes: dict) -> tuple:
    """The shape of :data:`WORK_FIELDS` field ``name`` for ``sizes`` (:func:`work_sizes`)."""
    return tuple(sizes[n] if isinstance(n, str) else n for n in WORK_FIELDS[name][0])


def new_work(system, ctrl: Controllers, params, empty=np.empty) -> Work:
    """The batch's :class:`Work`, robot axis first, padded: ``empty(shape, dtype)`` allocates
    each field (numpy's for the host; the CUDA backend passes its own)."""
    sizes = work_sizes(system, ctrl, params)
    n = system.n_points.shape[0]
    parts = [[empty((n, *work_shape(name, sizes)), dtype) for name, (_, dtype) in fields.items()]
             for fields in WORK_PARTS.values()]
    return Work(Blocks(*parts[0]), Joints(*parts[1]), Collisions(*parts[2]), Senses(*parts[3]),
                BrainState(*parts[4]), parts[5][0])


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
def _observe(k, robot, ground, blocks, at, params, out):
    """Update the episode's diagnostics ``out`` (D_*) with control step ``k``; ``blocks``: the
    robot's :class:`Blocks`; ``at``: its centre of mass (x, y), tilt [deg] and a terrain
    segment near it."""
    if k <= SETTLE_STEPS:
        return
    cx, cy, tilt, near = at
    mass, vel = robot.mass, blocks.body_vel
    gap = lowest_gap(robot, ground, blocks.body_pos, blocks.cos, blocks.sin, near)
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
    pos, contact = state.work.blocks.pos, state.scratch.contact
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
    """Robot ``b``'s :class:`Work`, allocated to its own sizes (:data:`WORK_PARTS`)."""
    p = system.n_points[b]
    s = system.n_springs[b]
    v = system.n_voxels[b]
    n = ctrl.n_nodes[b]
    c = contact_capacity(p, system.n_pairs[b])
    return Work(
        Blocks(np.empty(p), np.empty(p), np.empty(p), np.empty(p), np.empty((p, 3)),
               np.empty((p, 3)), np.empty((p, 2)), np.empty((p, 2))),
        Joints(np.empty(s), np.empty((s, N_SPRING_COLUMNS)),
               np.empty((system.n_ropes[b], N_ROPE_COLUMNS)),
               np.empty((system.n_welds[b], N_WELD_COLUMNS))),
        Collisions(np.empty((c, N_CONTACT_COLUMNS)), np.empty((c, N_CONTACT_COLUMNS)),
                   np.empty(2, dtype=np.int64), np.empty((2, 4, 4)), np.empty((2, 4)),
                   np.empty(p, dtype=np.bool_), np.empty(p + 1, dtype=np.int64)),
        Senses(np.empty((v, 6)), np.empty((v, int(params.touch_window))),
               np.empty((v, int(params.velocity_window), 2)), np.empty(system.n_readings[b])),
        BrainState(np.empty(v), np.empty(n), np.empty(n)),
        np.empty(N_TALLY),
    )


@njit(inline="always")
def _work_views(work, b, system, ctrl) -> Work:
    p = system.n_points[b]
    s = system.n_springs[b]
    v = system.n_voxels[b]
    n = ctrl.n_nodes[b]
    c = contact_capacity(p, system.n_pairs[b])
    blocks, joints, collisions, senses, brain = (work.blocks, work.joints, work.collisions,
                                                 work.senses, work.brain)
    return Work(
        Blocks(blocks.inv_mass[b, :p], blocks.inv_inertia[b, :p], blocks.cos[b, :p],
               blocks.sin[b, :p], blocks.body_pos[b, :p], blocks.body_vel[b, :p],
               blocks.pos[b, :p], blocks.vel[b, :p]),
        Joints(joints.rest[b, :s], joints.spring[b, :s], joints.rope[b, :system.n_ropes[b]],
               joints.weld[b, :system.n_welds[b]]),
        Collisions(collisions.contacts[b, :c], collisions.previous[b, :c], collisions.counts[b],
                   collisions.polygon[b], collisions.clipped[b], collisions.contact[b, :p],
                   collisions.segment[b, :p + 1]),
        Senses(senses.voxels[b, :v], senses.touch_hist[b, :v], senses.vel_hist[b, :v],
               senses.readings[b, :system.n_readings[b]]),
        BrainState(brain.actuation[b, :v], brain.h_prev[b, :n], brain.h_next[b, :n]),
        work.tally[b],
    )


@njit
def work_row(work, b, system, ctrl) -> Work:
    """Robot ``b``'s :class:`Work` as views of a batch's (:func:`new_work`), trimmed to its own
    sizes (:data:`WORK_FIELDS`): a GPU thread cannot allocate, the stepper keeps the state."""
    return _work_views(work, b, system, ctrl)


@uncounted
def uncounted_work_row(work, b, system, ctrl) -> Work:
    """:func:`work_row` for kernels compiled without reference counting (``_jit.uncounted``), and
    only for them: the compiled :func:`work_row` returns views that it has counted, which such
    a kernel never releases (each batch's arrays then stayed in memory: 11 MB a batch of 96
    worms); these views are counted by no one, as the kernel's own are not."""
    return _work_views(work, b, system, ctrl)


@njit
def robot_state(system, b, params, work, rays) -> RobotState:
    """Robot ``b``'s :class:`RobotState` over ``work`` (its :func:`robot_work` or
    :func:`work_row`) and ``rays`` (:func:`~somite.sim.sensors.lidar_rays`)."""
    fill_robot(system, b, params, work.blocks.inv_mass, work.blocks.inv_inertia)
    return filled_state(system, b, work, rays)


@njit(inline="always")
def filled_state(system, b, work, rays) -> RobotState:
    """:func:`robot_state` over a ``work`` that it has filled before."""
    robot = filled_robot(system, b, work.blocks.inv_mass, work.blocks.inv_inertia)
    joints, collisions = work.joints, work.collisions
    scratch = Scratch(joints.rest, work.blocks.cos, work.blocks.sin, joints.spring, joints.rope,
                      joints.weld, collisions.contacts, collisions.previous, collisions.counts,
                      collisions.polygon, collisions.clipped, collisions.contact,
                      collisions.segment)
    return RobotState(robot, ground_view(system, b), scratch, work, rays)


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
    scratch = state.scratch
    work = state.work
    reset_scratch(robot, scratch)
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_readings = system.n_readings[b]
    body_pos = work.blocks.body_pos
    body_vel = work.blocks.body_vel
    touch_hist = work.senses.touch_hist
    vel_hist = work.senses.vel_hist
    h_prev = work.brain.h_prev
    h_next = work.brain.h_next
    for p in range(n_points):
        body_pos[p, 0] = system.initial_pos[b, p, 0]
        body_pos[p, 1] = system.initial_pos[b, p, 1]
        body_pos[p, 2] = 0.0
        body_vel[p, 0] = body_vel[p, 1] = body_vel[p, 2] = 0.0
    corner_state(robot, body_pos, body_vel, scratch.cos, scratch.sin, work.blocks.pos,
                 work.blocks.vel)
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
    before_physics(state.robot, state.work.brain.actuation, params, state.scratch.rest)
    blocks = state.work.blocks
    advance(state.robot, state.ground, state.scratch, blocks.body_pos, blocks.body_vel, params,
            int(params.substeps))
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
    scratch = state.scratch
    work = state.work
    n_points = robot.n_points
    n_voxels = robot.n_voxels
    n_readings = system.n_readings[b]
    mass = robot.mass
    voxel_x = system.voxel_x[b]
    body_pos = work.blocks.body_pos
    body_vel = work.blocks.body_vel
    pos = work.blocks.pos
    vel = work.blocks.vel
    voxels = work.senses.voxels
    readings = work.senses.readings
    actuation = work.brain.actuation
    tally = work.tally
    corner_state(robot, body_pos, body_vel, scratch.cos, scratch.sin, pos, vel)
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
    near = scratch.segment[robot.n_points]
    tilt = _column_tilt(n_voxels, voxel_x, tally[T_X_LO], tally[T_X_HI], voxels)
    _observe(k, robot, ground, work.blocks, (cx, cy, tilt, near), params, trace.diagnostics[b])
    senses = work.senses
    sensing = Sensing(n_readings, system.reading_code[b], system.reading_voxel[b], voxels,
                      senses.touch_hist, senses.vel_hist, state.rays)
    update_histories(k - 1, n_voxels, robot.corners, scratch.contact, sensing, params)
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
