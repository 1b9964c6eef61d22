"""One control step of somite's physics in plain Python and NumPy: a slow oracle of
:func:`somite.sim.physics.advance`, written to be read, not to be fast.

The robot is one rigid square block per voxel corner (docs/original-system.md section 1.2),
joined by soft springs, rope limits and welds, touching the ground and, where they share no
joint, each other. A control step is ``params.substeps`` steps of dyn4j 3.3 (the engine under
2D-VSR-Sim), each in this order (:func:`step`); dyn4j's names in brackets:

1. :func:`apply_gravity_and_damping` (``Island.solve``, integrating the velocities);
2. :func:`set_up_contacts`, with last step's impulses (``SequentialImpulses.initialize``);
3. :func:`set_up_springs`, :func:`set_up_ropes`, :func:`set_up_welds`, likewise
   (``DistanceJoint``, ``RopeJoint``, ``WeldJoint``: ``initializeConstraints``);
4. ``velocity_iterations`` passes over the springs, ropes, welds, then the contacts
   (:func:`solve_springs` ... :func:`solve_contacts`; ``solveVelocityConstraints``);
5. :func:`move_bodies` (``Island.solve``, integrating the positions);
6. at most ``position_iterations`` passes over the contacts, ropes and welds, stopping once all
   of them hold (:func:`fix_contacts` ... :func:`fix_welds`; ``solvePositionConstraints``);
7. :func:`find_contacts` for the next step (``World.detect``: separating axes, ``Sat``; the
   clipping manifold, ``ClippingManifoldSolver``; warm start by feature,
   ``IndexedManifoldPointId``).

The passes are Gauss-Seidel: every joint and contact sees the velocities (or positions) that
the ones before it left, so the order of the joints and contacts is part of the physics, and
this file keeps the kernel's. It also keeps the kernel's arithmetic expression by expression,
so that the two agree to rounding (the kernel takes its sines and cosines from a polynomial,
this file from libm), not merely to the model. A body's rotation is always the cosine and sine
of its angle: the kernel caches them, this file takes them afresh where it needs them.

Vectors are (x, y) tuples of floats; ``pos`` and ``vel`` (P, 3) hold each block's centre and
angle, velocity and angular velocity. Copying the kernel's arrays in and out:
tests/test_reference_step.py.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from somite.sim.config import BLOCK_SIDE

# dyn4j's Settings (docs/original-system.md section 1.1).
LINEAR_SLOP = 0.005  # [m] linear tolerance: error the position passes leave alone
ANGULAR_SLOP = 2.0 * math.pi / 180.0  # [rad] angular tolerance, 2 degrees
MAX_CORRECTION = 0.2  # [m] largest linear correction of one position pass
BAUMGARTE = 0.2  # share of a contact's penetration one position pass removes
MAX_TRANSLATION = 2.0  # [m] largest move of a body in one step
MAX_ROTATION = 0.5 * math.pi  # [rad] largest turn of a body in one step
RESTITUTION_SPEED = 1.0  # [m/s] slower impacts do not bounce
# The block solver's limit (Box2D's and dyn4j's): a two-point contact worse conditioned than
# this keeps only its deeper point.
CONDITION_LIMIT = 1000.0
# The ground under a terrain segment: a quadrilateral this deep [m] below its lower end.
GROUND_DEPTH = 50.0

HALF_BLOCK = BLOCK_SIDE / 2
# A block's corners and its edges' outward normals in its own frame, counter-clockwise from
# the lower left; edge j runs from corner j to corner j + 1.
BLOCK_CORNERS = ((-HALF_BLOCK, -HALF_BLOCK), (HALF_BLOCK, -HALF_BLOCK), (HALF_BLOCK, HALF_BLOCK),
                 (-HALF_BLOCK, HALF_BLOCK))
BLOCK_NORMALS = ((0.0, -1.0), (1.0, 0.0), (0.0, 1.0), (-1.0, 0.0))


@dataclass
class Robot:
    """What a step does not change: the blocks' inverse masses, the joints, the pairs of blocks
    that may collide, and the terrain. Offsets are in a block's own frame, from its centre."""

    inv_mass: np.ndarray  # (P,) [1/kg]
    inv_inertia: np.ndarray  # (P,) [1/(kg m^2)]
    spring_ends: np.ndarray  # (S, 2) blocks a, b
    spring_anchor: np.ndarray  # (S, 4) the anchor on a (x, y), then on b
    rope_ends: np.ndarray  # (Y, 2)
    weld_ends: np.ndarray  # (W, 2)
    weld_anchor: np.ndarray  # (W, 2) a's centre, as an offset on b
    pair_ends: np.ndarray  # (C, 2) blocks that share no joint
    ground_x: np.ndarray  # (K,) the terrain's vertices, x increasing [m]
    ground_y: np.ndarray  # (K,)

    @property
    def contact_capacity(self) -> int:
        """Most contact points a step keeps (the kernel's table: 6 per block, 2 per pair)."""
        return 6 * len(self.inv_mass) + 2 * len(self.pair_ends)


@dataclass
class Contact:
    """One contact point: it pushes block ``a`` along ``normal`` and ``b`` (-1: the ground)
    the other way. The points of one pair of bodies (one or two) are adjacent in the list."""

    a: int
    b: int
    feature: int  # which vertex against which edge: how a point is recognised next step
    point: tuple  # where it was found (world)
    depth: float  # [m] how far it was inside the other body
    normal: tuple
    local_a: tuple  # the point in a's frame
    local_b: tuple  # the point in b's frame (the world's for the ground)
    count: int  # points of its pair on the pair's first point, 0 on the second
    mu: float  # friction coefficient
    jn: float = 0.0  # accumulated normal impulse (warm start: last step's)
    jt: float = 0.0  # accumulated tangent impulse
    live: bool = True  # False: the block solver dropped it for this step
    # Set up at the start of a step (set_up_contacts):
    ra: tuple = (0.0, 0.0)  # offset of the point from a's centre (world)
    rb: tuple = (0.0, 0.0)  # from b's centre; (0, 0) for the ground
    mass_n: float = 0.0  # effective mass along the normal
    mass_t: float = 0.0  # along the tangent
    bounce: float = 0.0  # normal speed restitution asks for
    jp: float = 0.0  # accumulated position impulse of this step


@dataclass
class State:
    """What one step hands to the next (the kernel's pos, vel and scratch arrays)."""

    pos: np.ndarray  # (P, 3) x, y [m], angle [rad]
    vel: np.ndarray  # (P, 3) [m/s], [rad/s]
    rest: np.ndarray  # (S,) [m] the springs' rest lengths (set by the actuation)
    spring_impulse: np.ndarray  # (S,) accumulated, warm-starts the next step
    rope_impulse: np.ndarray  # (Y,)
    weld_impulse: np.ndarray  # (W, 3) x, y, angle
    contacts: list = field(default_factory=list)  # list[Contact] for the next step
    touching: np.ndarray | None = None  # (P,) bool: the block touches the ground
    rope_active: np.ndarray | None = None  # (Y,) bool: the rope limits in force last step


# small vector helpers -----------------------------------------------------------------------


def turned(angle: float, offset) -> tuple:
    """Offset (x, y) in a body's frame at ``angle``, turned into the world's."""
    c, s = math.cos(angle), math.sin(angle)
    return c * offset[0] - s * offset[1], s * offset[0] + c * offset[1]


def cross(r, j) -> float:
    """The 2-D cross product r x j (the torque of impulse j at offset r)."""
    return r[0] * j[1] - r[1] * j[0]


def push(x: np.ndarray, robot: Robot, a: int, b: int, ra, rb, j) -> None:
    """Impulse j on body a at offset ra and its opposite on body b at rb (b < 0: the ground,
    which does not move). ``x`` is ``vel``, or ``pos`` in the position passes."""
    x[a, 0] += j[0] * robot.inv_mass[a]
    x[a, 1] += j[1] * robot.inv_mass[a]
    x[a, 2] += robot.inv_inertia[a] * cross(ra, j)
    if b >= 0:
        x[b, 0] -= j[0] * robot.inv_mass[b]
        x[b, 1] -= j[1] * robot.inv_mass[b]
        x[b, 2] -= robot.inv_inertia[b] * cross(rb, j)


def relative_velocity(vel: np.ndarray, a: int, b: int, ra, rb) -> tuple:
    """Velocity of body a's point at ra relative to body b's point at rb (b < 0: the ground)."""
    va = (vel[a, 0] - vel[a, 2] * ra[1], vel[a, 1] + vel[a, 2] * ra[0])
    if b < 0:
        return va
    return va[0] - (vel[b, 0] - vel[b, 2] * rb[1]), va[1] - (vel[b, 1] + vel[b, 2] * rb[0])


def direction(x: float, y: float) -> tuple:
    """(x, y) scaled to length 1, and its length; shorter than LINEAR_SLOP: no direction,
    (0, 0) (dyn4j's rule)."""
    length = math.sqrt(x * x + y * y)
    if length < LINEAR_SLOP:
        return (0.0, 0.0), length
    return (x / length, y / length), length


def solve33(k, rhs) -> tuple:
    """x of the symmetric 3x3 system K x = rhs, K given as (k00, k01, k02, k11, k12, k22), by
    Cramer's rule (x = 0 if K is singular), term by term as the kernel writes it."""
    a00, a01, a02, a11, a12, a22 = k
    bx, by, bz = rhs
    c00 = a11 * a22 - a12 * a12
    c01 = a01 * a22 - a12 * a02
    c02 = a01 * a12 - a11 * a02
    det = a00 * c00 - a01 * c01 + a02 * c02
    inverse = 1.0 / det if det != 0.0 else 0.0
    return (inverse * (bx * c00 - a01 * (by * a22 - a12 * bz) + a02 * (by * a12 - a11 * bz)),
            inverse * (a00 * (by * a22 - bz * a12) - bx * c01 + a02 * (a01 * bz - by * a02)),
            inverse * (a00 * (a11 * bz - a12 * by) - a01 * (a01 * bz - by * a02) + bx * c02))


# 1. velocities ------------------------------------------------------------------------------


def apply_gravity_and_damping(params, vel: np.ndarray) -> None:
    """dyn4j's ``Island.solve``, integrating the velocities: gravity for dt, then damping, the
    velocity times clamp(1 - dt * drag, 0, 1)."""
    keep = min(max(1.0 - params.dt * params.drag, 0.0), 1.0)
    vel[:, 1] -= params.gravity * params.dt
    vel *= keep


# 2. contacts: set-up and velocity passes ----------------------------------------------------


def pair_matrix(robot: Robot, first: Contact, second: Contact) -> tuple:
    """(k00, k01, k11): the 2x2 matrix that maps a two-point contact's normal impulses to its
    points' normal velocities."""
    a, b = first.a, first.b
    nx, ny = first.normal
    m = robot.inv_mass[a] + (robot.inv_mass[b] if b >= 0 else 0.0)
    iia = robot.inv_inertia[a]
    iib = robot.inv_inertia[b] if b >= 0 else 0.0
    r1a, r1b = cross(first.ra, (nx, ny)), cross(first.rb, (nx, ny))
    r2a, r2b = cross(second.ra, (nx, ny)), cross(second.rb, (nx, ny))
    return (m + iia * r1a * r1a + iib * r1b * r1b, m + iia * r1a * r2a + iib * r1b * r2b,
            m + iia * r2a * r2a + iib * r2b * r2b)


def set_up_contacts(robot: Robot, params, state: State) -> None:
    """dyn4j's ``SequentialImpulses.initialize``: each point's offsets from the bodies'
    centres, effective masses along the normal and the tangent, and the bounce restitution
    asks of an impact faster than RESTITUTION_SPEED; a two-point contact whose block system is
    ill-conditioned keeps only its deeper point; then last step's impulses are applied (warm
    start)."""
    pos, vel = state.pos, state.vel
    for c in state.contacts:
        a, b = c.a, c.b
        nx, ny = c.normal
        c.ra = (c.point[0] - pos[a, 0], c.point[1] - pos[a, 1])
        c.rb = (c.point[0] - pos[b, 0], c.point[1] - pos[b, 1]) if b >= 0 else (0.0, 0.0)
        ima, iia = robot.inv_mass[a], robot.inv_inertia[a]
        imb = robot.inv_mass[b] if b >= 0 else 0.0
        iib = robot.inv_inertia[b] if b >= 0 else 0.0
        rna, rnb = cross(c.ra, (nx, ny)), cross(c.rb, (nx, ny))
        c.mass_n = 1.0 / (ima + imb + iia * rna * rna + iib * rnb * rnb)
        rta, rtb = cross(c.ra, (ny, -nx)), cross(c.rb, (ny, -nx))
        c.mass_t = 1.0 / (ima + imb + iia * rta * rta + iib * rtb * rtb)
        vx, vy = relative_velocity(vel, a, b, c.ra, c.rb)
        vn = vx * nx + vy * ny
        c.bounce = -params.restitution * vn if vn < -RESTITUTION_SPEED else 0.0
        c.jp = 0.0
    for k, c in enumerate(state.contacts):
        if c.count != 2:
            continue
        second = state.contacts[k + 1]
        k00, k01, k11 = pair_matrix(robot, c, second)
        if not k00 * k00 < CONDITION_LIMIT * (k00 * k11 - k01 * k01):
            # The shallower point goes (the first one on a tie).
            (second if c.depth > second.depth else c).live = False
    for c in state.contacts:
        if c.live:
            nx, ny = c.normal
            push(vel, robot, c.a, c.b, c.ra, c.rb,
                 (nx * c.jn + ny * c.jt, ny * c.jn - nx * c.jt))


def solve_friction(robot: Robot, vel: np.ndarray, c: Contact) -> None:
    """Coulomb friction at one point: the tangent impulse that stops its sliding, its total
    kept within mu times the normal impulse."""
    tx, ty = c.normal[1], -c.normal[0]
    vx, vy = relative_velocity(vel, c.a, c.b, c.ra, c.rb)
    j = -c.mass_t * (vx * tx + vy * ty)
    limit = c.mu * c.jn
    before = c.jt
    c.jt = max(-limit, min(before + j, limit))
    j = c.jt - before
    push(vel, robot, c.a, c.b, c.ra, c.rb, (tx * j, ty * j))


def solve_normal(robot: Robot, vel: np.ndarray, c: Contact) -> None:
    """One point's normal impulse: what stops it approaching (or gives its bounce), the total
    kept >= 0 (a contact pushes, never pulls)."""
    nx, ny = c.normal
    vx, vy = relative_velocity(vel, c.a, c.b, c.ra, c.rb)
    j = -c.mass_n * (vx * nx + vy * ny - c.bounce)
    before = c.jn
    c.jn = max(before + j, 0.0)
    j = c.jn - before
    push(vel, robot, c.a, c.b, c.ra, c.rb, (nx * j, ny * j))


def solve_pair(robot: Robot, vel: np.ndarray, first: Contact, second: Contact) -> None:
    """Both normal impulses of a two-point contact at once (the block solver of Box2D and
    dyn4j): the first of four cases that gives non-negative impulses and non-negative
    approach speeds: both points pushing, only the first, only the second, neither."""
    a, b = first.a, first.b
    nx, ny = first.normal
    k00, k01, k11 = pair_matrix(robot, first, second)
    det = k00 * k11 - k01 * k01
    i00, i01, i11 = k11 / det, -k01 / det, k00 / det
    a1, a2 = first.jn, second.jn
    v1x, v1y = relative_velocity(vel, a, b, first.ra, first.rb)
    v2x, v2y = relative_velocity(vel, a, b, second.ra, second.rb)
    # The points' normal speeds with the accumulated impulses taken out.
    b1 = v1x * nx + v1y * ny - first.bounce - (k00 * a1 + k01 * a2)
    b2 = v2x * nx + v2y * ny - second.bounce - (k01 * a1 + k11 * a2)
    x1 = -(i00 * b1 + i01 * b2)
    x2 = -(i01 * b1 + i11 * b2)
    if not (x1 >= 0.0 and x2 >= 0.0):
        x1, x2 = -first.mass_n * b1, 0.0
        if not (x1 >= 0.0 and k01 * x1 + b2 >= 0.0):
            x1, x2 = 0.0, -second.mass_n * b2
            if not (x2 >= 0.0 and k01 * x2 + b1 >= 0.0):
                x1 = x2 = 0.0
                if not (b1 >= 0.0 and b2 >= 0.0):
                    return  # no case holds: leave the impulses as they are
    d1, d2 = x1 - a1, x2 - a2
    push(vel, robot, a, b, first.ra, first.rb, (nx * d1, ny * d1))
    push(vel, robot, a, b, second.ra, second.rb, (nx * d2, ny * d2))
    first.jn, second.jn = x1, x2


def solve_contacts(robot: Robot, state: State) -> None:
    """One velocity pass over the contacts (dyn4j's ``solveVelocityContraints``), pair of
    bodies by pair: friction at each live point first, then the normal impulses, both points
    at once where both are live."""
    contacts, vel = state.contacts, state.vel
    k = 0
    while k < len(contacts):
        pair = contacts[k:k + contacts[k].count]
        for c in pair:
            if c.live:
                solve_friction(robot, vel, c)
        if len(pair) == 2 and pair[0].live and pair[1].live:
            solve_pair(robot, vel, pair[0], pair[1])
        else:
            for c in pair:
                if c.live:
                    solve_normal(robot, vel, c)
        k += len(pair)


# 3. joints: set-up and velocity passes ------------------------------------------------------


@dataclass
class SpringRow:
    """A spring's terms for this step."""

    ra: tuple  # anchor offsets from the bodies' centres (world)
    rb: tuple
    normal: tuple  # from b's anchor towards a's
    mass: float  # effective mass, softened
    gamma: float  # softness
    bias: float  # the stiffness's share of the velocity target


def set_up_springs(robot: Robot, params, state: State) -> list:
    """dyn4j's ``DistanceJoint.initializeConstraints`` for a soft joint (frequency
    ``spring_hz``, damping ratio ``damping_ratio``): each spring's direction, its effective
    mass along it, and the softness gamma and bias that turn stiffness and damping into a
    velocity constraint; then last step's impulse is applied (warm start)."""
    pos, vel, dt = state.pos, state.vel, params.dt
    omega = 2.0 * math.pi * params.spring_hz
    rows = []
    for s, (a, b) in enumerate(robot.spring_ends):
        ima, iia = robot.inv_mass[a], robot.inv_inertia[a]
        imb, iib = robot.inv_mass[b], robot.inv_inertia[b]
        ra = turned(pos[a, 2], robot.spring_anchor[s, :2])
        rb = turned(pos[b, 2], robot.spring_anchor[s, 2:])
        (nx, ny), length = direction(pos[a, 0] + ra[0] - pos[b, 0] - rb[0],
                                     pos[a, 1] + ra[1] - pos[b, 1] - rb[1])
        cra, crb = cross(ra, (nx, ny)), cross(rb, (nx, ny))
        w = ima + iia * cra * cra + imb + iib * crb * crb
        mass = 1.0 / w if w > 0.0 else 0.0
        stiffness = mass * omega * omega
        damping = 2.0 * mass * params.damping_ratio * omega
        gamma = dt * (damping + dt * stiffness)
        gamma = 1.0 / gamma if gamma > 0.0 else 0.0
        w += gamma
        rows.append(SpringRow(ra, rb, (nx, ny), 1.0 / w if w > 0.0 else 0.0, gamma,
                              (length - state.rest[s]) * dt * stiffness * gamma))
        j = state.spring_impulse[s]
        push(vel, robot, a, b, ra, rb, (nx * j, ny * j))
    return rows


def solve_springs(robot: Robot, state: State, rows: list) -> None:
    """One velocity pass over the springs (``DistanceJoint.solveVelocityConstraints``)."""
    vel = state.vel
    for s, (a, b) in enumerate(robot.spring_ends):
        row = rows[s]
        nx, ny = row.normal
        vx, vy = relative_velocity(vel, a, b, row.ra, row.rb)
        j = -row.mass * (nx * vx + ny * vy + row.bias + row.gamma * state.spring_impulse[s])
        state.spring_impulse[s] += j
        push(vel, robot, a, b, row.ra, row.rb, (nx * j, ny * j))


def set_up_ropes(robot: Robot, state: State) -> list:
    """dyn4j's ``RopeJoint.initializeConstraints`` with a lower limit only: a rope limit
    between two adjacent blocks of a voxel is in force while their centres are closer than
    one block side, and then holds their distance both ways; one out of force forgets its
    impulse. Returns each limit's (normal, effective mass), None when out of force."""
    pos, vel = state.pos, state.vel
    rows = []
    for r, (a, b) in enumerate(robot.rope_ends):
        (nx, ny), length = direction(pos[a, 0] - pos[b, 0], pos[a, 1] - pos[b, 1])
        if length < BLOCK_SIDE:
            rows.append(((nx, ny), 1.0 / (robot.inv_mass[a] + robot.inv_mass[b])))
            j = state.rope_impulse[r]
            push(vel, robot, a, b, (0.0, 0.0), (0.0, 0.0), (nx * j, ny * j))
        else:
            rows.append(None)
            state.rope_impulse[r] = 0.0
    state.rope_active = np.array([row is not None for row in rows], dtype=bool)
    return rows


def solve_ropes(robot: Robot, state: State, rows: list) -> None:
    """One velocity pass over the rope limits in force (between the blocks' centres)."""
    vel = state.vel
    for r, (a, b) in enumerate(robot.rope_ends):
        if rows[r] is None:
            continue
        (nx, ny), mass = rows[r]
        j = -mass * (nx * (vel[a, 0] - vel[b, 0]) + ny * (vel[a, 1] - vel[b, 1]))
        state.rope_impulse[r] += j
        push(vel, robot, a, b, (0.0, 0.0), (0.0, 0.0), (nx * j, ny * j))


def weld_matrix(robot: Robot, a: int, b: int, rb) -> tuple:
    """The weld's 3x3 effective-mass matrix (k00, k01, k02, k11, k12, k22); its anchor sits on
    a's centre, so a's offset is zero."""
    ima, iia = robot.inv_mass[a], robot.inv_inertia[a]
    imb, iib = robot.inv_mass[b], robot.inv_inertia[b]
    rbx, rby = rb
    return (ima + imb + rby * rby * iib, -rby * rbx * iib, -rby * iib,
            ima + imb + rbx * rbx * iib, rbx * iib, iia + iib)


def push_weld(x: np.ndarray, robot: Robot, a: int, b: int, rb, j) -> None:
    """A weld's impulse j = (x, y, angle) on a at its centre, the opposite on b at rb."""
    x[a, 0] += j[0] * robot.inv_mass[a]
    x[a, 1] += j[1] * robot.inv_mass[a]
    x[a, 2] += robot.inv_inertia[a] * j[2]
    x[b, 0] -= j[0] * robot.inv_mass[b]
    x[b, 1] -= j[1] * robot.inv_mass[b]
    x[b, 2] -= robot.inv_inertia[b] * (cross(rb, j[:2]) + j[2])


def set_up_welds(robot: Robot, state: State) -> list:
    """dyn4j's ``WeldJoint.initializeConstraints``: each weld's anchor offset on its second
    body; then last step's impulse is applied (warm start). Returns the offsets."""
    rows = []
    for q, (a, b) in enumerate(robot.weld_ends):
        rb = turned(state.pos[b, 2], robot.weld_anchor[q])
        rows.append(rb)
        push_weld(state.vel, robot, a, b, rb, tuple(state.weld_impulse[q]))
    return rows


def solve_welds(robot: Robot, state: State, rows: list) -> None:
    """One velocity pass over the welds (``WeldJoint.solveVelocityConstraints``): the impulse
    that stops all relative motion of the two bodies at once (a 3x3 solve)."""
    vel = state.vel
    for q, (a, b) in enumerate(robot.weld_ends):
        rb = rows[q]
        vx, vy = relative_velocity(vel, a, b, (0.0, 0.0), rb)
        j = solve33(weld_matrix(robot, a, b, rb), (-vx, -vy, -(vel[a, 2] - vel[b, 2])))
        state.weld_impulse[q] += j
        push_weld(vel, robot, a, b, rb, j)


# 4. positions -------------------------------------------------------------------------------


def move_bodies(params, state: State) -> None:
    """dyn4j's ``Island.solve``, integrating the positions: each body moves with its velocity
    for dt, a velocity that would move it farther than MAX_TRANSLATION or turn it more than
    MAX_ROTATION cut down to that."""
    pos, vel, dt = state.pos, state.vel, params.dt
    tx, ty = vel[:, 0] * dt, vel[:, 1] * dt
    square = tx * tx + ty * ty
    fast = square > MAX_TRANSLATION * MAX_TRANSLATION
    vel[fast, :2] *= (MAX_TRANSLATION / np.sqrt(square[fast]))[:, None]
    rotation = vel[:, 2] * dt
    spinning = rotation * rotation > MAX_ROTATION * MAX_ROTATION
    vel[spinning, 2] *= MAX_ROTATION / np.abs(rotation[spinning])
    pos += vel * dt


def fix_contacts(robot: Robot, state: State) -> bool:
    """One position pass over the live contact points (dyn4j's ``solvePositionContraints``):
    each point's separation now, along the normal it was found with; a point deeper than
    LINEAR_SLOP is pushed out by BAUMGARTE of the excess (at most MAX_CORRECTION), the
    step's total position impulse kept >= 0. Whether no point is deeper than 3 LINEAR_SLOP."""
    pos = state.pos
    deepest = 0.0
    for c in state.contacts:
        if not c.live:
            continue
        a, b = c.a, c.b
        nx, ny = c.normal
        ra = turned(pos[a, 2], c.local_a)
        pa = (pos[a, 0] + ra[0], pos[a, 1] + ra[1])
        if b >= 0:
            rb = turned(pos[b, 2], c.local_b)
            pb = (pos[b, 0] + rb[0], pos[b, 1] + rb[1])
        else:
            rb, pb = (0.0, 0.0), c.local_b
        separation = (pa[0] - pb[0]) * nx + (pa[1] - pb[1]) * ny - c.depth
        deepest = min(deepest, separation)
        correction = BAUMGARTE * min(max(separation + LINEAR_SLOP, -MAX_CORRECTION), 0.0)
        rna, rnb = cross(ra, (nx, ny)), cross(rb, (nx, ny))
        w = robot.inv_mass[a] + robot.inv_inertia[a] * rna * rna
        if b >= 0:
            w += robot.inv_mass[b] + robot.inv_inertia[b] * rnb * rnb
        before = c.jp
        c.jp = max(before + -correction / w, 0.0)
        j = c.jp - before
        push(pos, robot, a, b, ra, rb, (nx * j, ny * j))
    return deepest >= -3.0 * LINEAR_SLOP


def fix_ropes(robot: Robot, state: State) -> bool:
    """One position pass over the rope limits (``RopeJoint.solvePositionConstraints``): two
    blocks closer than a block side are pushed apart, at most MAX_CORRECTION a pass. Whether
    none was more than LINEAR_SLOP too close."""
    pos = state.pos
    held = True
    for a, b in robot.rope_ends:
        nx, ny = pos[a, 0] - pos[b, 0], pos[a, 1] - pos[b, 1]
        length = math.sqrt(nx * nx + ny * ny)
        if length >= BLOCK_SIDE:
            continue
        if length > 0.0:
            nx, ny = nx / length, ny / length
        error = max(length - BLOCK_SIDE, -MAX_CORRECTION)
        j = -error / (robot.inv_mass[a] + robot.inv_mass[b])
        push(pos, robot, a, b, (0.0, 0.0), (0.0, 0.0), (nx * j, ny * j))
        if -error >= LINEAR_SLOP:
            held = False
    return held


def fix_welds(robot: Robot, state: State) -> bool:
    """One position pass over the welds (``WeldJoint.solvePositionConstraints``, rigid): the
    whole error, the anchor's gap and the angle between the bodies (wrapped into
    [-pi, pi]), removed at once by a 3x3 solve. Whether every weld was within LINEAR_SLOP and
    ANGULAR_SLOP."""
    pos = state.pos
    held = True
    for q, (a, b) in enumerate(robot.weld_ends):
        rb = turned(pos[b, 2], robot.weld_anchor[q])
        cx = pos[a, 0] - pos[b, 0] - rb[0]
        cy = pos[a, 1] - pos[b, 1] - rb[1]
        angle = pos[a, 2] - pos[b, 2]
        if angle < -math.pi:
            angle += 2.0 * math.pi
        if angle > math.pi:
            angle -= 2.0 * math.pi
        j = solve33(weld_matrix(robot, a, b, rb), (-cx, -cy, -angle))
        push_weld(pos, robot, a, b, rb, j)
        if math.sqrt(cx * cx + cy * cy) > LINEAR_SLOP or abs(angle) > ANGULAR_SLOP:
            held = False
    return held


# 5. contact finding -------------------------------------------------------------------------


def block_polygon(pos: np.ndarray, p: int) -> np.ndarray:
    """Block p as a polygon (4, 4): its corners (x, y) and its edges' outward normals, in the
    world, counter-clockwise from its own lower left corner."""
    poly = np.empty((4, 4))
    c, s = math.cos(pos[p, 2]), math.sin(pos[p, 2])
    for j, ((lx, ly), (nx, ny)) in enumerate(zip(BLOCK_CORNERS, BLOCK_NORMALS)):
        poly[j] = (pos[p, 0] + c * lx - s * ly, pos[p, 1] + s * lx + c * ly,
                   c * nx - s * ny, s * nx + c * ny)
    return poly


def ground_polygon(xs: np.ndarray, ys: np.ndarray, i: int) -> np.ndarray:
    """The ground under terrain segment i as a polygon like :func:`block_polygon`: the
    segment's left end, down GROUND_DEPTH below its lower end, across, and up to its right
    end."""
    base = min(ys[i], ys[i + 1]) - GROUND_DEPTH
    corners = ((xs[i], ys[i]), (xs[i], base), (xs[i + 1], base), (xs[i + 1], ys[i + 1]))
    poly = np.empty((4, 4))
    for j in range(4):
        (x0, y0), (x1, y1) = corners[j], corners[(j + 1) % 4]
        ex, ey = x1 - x0, y1 - y0
        length = math.sqrt(ex * ex + ey * ey)
        poly[j] = (x0, y0, ey / length, -ex / length)
    return poly


def deepest_axis(one: np.ndarray, two: np.ndarray) -> tuple:
    """The separating-axis test (dyn4j's ``Sat``) of two convex quadrilaterals: over the edge
    normals of both, the one along which they overlap least. Returns (overlap, normal from
    ``one`` towards ``two``), overlap 0 when some axis separates them (ties: the first)."""
    best, normal = math.inf, (0.0, 0.0)
    for side, (ref, other) in enumerate(((one, two), (two, one))):
        for j in range(4):
            ax, ay = ref[j, 2], ref[j, 3]
            depth = (ax * ref[j, 0] + ay * ref[j, 1]) - np.min(ax * other[:, 0] + ay * other[:, 1])
            if depth <= 0.0:
                return 0.0, (0.0, 0.0)
            if depth < best:
                best, normal = depth, ((ax, ay) if side == 0 else (-ax, -ay))
    return best, normal


def farthest_edge(poly: np.ndarray, n) -> tuple:
    """The edge of ``poly`` that faces direction n: at its vertex farthest along n (the first
    such), the one of its two edges whose outward normal is nearer n. Returns (first vertex,
    second vertex, farthest vertex)."""
    far = int(np.argmax(n[0] * poly[:, 0] + n[1] * poly[:, 1]))
    before = (far + 3) % 4
    if poly[before, 2] * n[0] + poly[before, 3] * n[1] < poly[far, 2] * n[0] + poly[far, 3] * n[1]:
        return far, (far + 1) % 4, far
    return before, far, far


def clip(points: list, n, offset: float) -> list:
    """The part of a segment (two points [x, y, vertex]) where n . p <= offset; an empty list
    when none of it is. A point cut off is replaced by the crossing, keeping its vertex."""
    if len(points) < 2:
        return []
    d0 = n[0] * points[0][0] + n[1] * points[0][1] - offset
    d1 = n[0] * points[1][0] + n[1] * points[1][1] - offset
    if d0 <= 0.0 and d1 <= 0.0:
        return points
    if d0 > 0.0 and d1 > 0.0:
        return []
    u = d0 / (d0 - d1)
    crossing = [points[0][0] + u * (points[1][0] - points[0][0]),
                points[0][1] + u * (points[1][1] - points[0][1])]
    if d0 > 0.0:
        return [crossing + [points[0][2]], points[1]]
    return [points[0], crossing + [points[1][2]]]


def manifold(one: np.ndarray, two: np.ndarray, n) -> tuple:
    """The contact points of two overlapping quadrilaterals, normal n from ``one`` towards
    ``two`` (dyn4j's ``ClippingManifoldSolver``): of the two edges facing each other, the one
    more perpendicular to n is the reference, the other (incident) is clipped to the
    reference's sides, and the clipped points behind the reference face are the contacts.
    Returns (points [x, y, incident vertex, depth], flipped (two holds the reference), the
    reference and incident edges' first vertices, the reference face's normal from ``one``
    towards ``two``)."""
    r1, r2, rm = farthest_edge(one, n)
    i1, i2, im = farthest_edge(two, (-n[0], -n[1]))
    e1 = (one[r2, 0] - one[r1, 0], one[r2, 1] - one[r1, 1])
    e2 = (two[i2, 0] - two[i1, 0], two[i2, 1] - two[i1, 1])
    flipped = abs(e1[0] * n[0] + e1[1] * n[1]) > abs(e2[0] * n[0] + e2[1] * n[1])
    ref, inc = (two, one) if flipped else (one, two)
    if flipped:
        r1, r2, rm, i1, i2 = i1, i2, im, r1, r2
    ex, ey = ref[r2, 0] - ref[r1, 0], ref[r2, 1] - ref[r1, 1]
    length = math.sqrt(ex * ex + ey * ey)
    ex, ey = ex / length, ey / length
    points = [[inc[i1, 0], inc[i1, 1], i1], [inc[i2, 0], inc[i2, 1], i2]]
    points = clip(points, (-ex, -ey), -(ex * ref[r1, 0] + ey * ref[r1, 1]))
    points = clip(points, (ex, ey), ex * ref[r2, 0] + ey * ref[r2, 1])
    fx, fy = -ey, ex  # the reference face's inward normal
    normal = (fx, fy) if flipped else (-fx, -fy)
    if len(points) < 2:
        return [], flipped, r1, i1, normal
    front = fx * ref[rm, 0] + fy * ref[rm, 1]
    kept = []
    for x, y, vertex in points:
        depth = fx * x + fy * y - front
        if depth >= 0.0:
            kept.append([x, y, vertex, depth])
    return kept, flipped, r1, i1, normal


def local(pos: np.ndarray, p: int, point) -> tuple:
    """World ``point`` in body p's frame."""
    c, s = math.cos(pos[p, 2]), math.sin(pos[p, 2])
    dx, dy = point[0] - pos[p, 0], point[1] - pos[p, 1]
    return c * dx + s * dy, -s * dx + c * dy


def add_contacts(robot: Robot, pos: np.ndarray, old: list, new: list, a: int, b: int,
                 partner: int, one: np.ndarray, two: np.ndarray, mu: float) -> int:
    """The contact points of block a (polygon ``two``) with body b (polygon ``one``; b = -1:
    the ground, ``partner`` its segment; else ``partner`` = b), appended to ``new`` unless
    the table is full, each starting from the impulses of last step's live point of the same
    bodies and feature. Returns how many."""
    overlap, n = deepest_axis(one, two)
    if overlap <= 0.0:
        return 0
    points, flipped, ref, inc, normal = manifold(one, two, n)
    if not points or len(new) + len(points) > robot.contact_capacity:
        return 0
    for q, (x, y, vertex, depth) in enumerate(points):
        feature = (((partner * 2 + int(flipped)) * 4 + ref) * 4 + inc) * 4 + vertex
        contact = Contact(a, b, feature, (x, y), depth, normal, local(pos, a, (x, y)),
                          local(pos, b, (x, y)) if b >= 0 else (x, y),
                          len(points) if q == 0 else 0, mu)
        for last in old:
            if last.feature == feature and last.a == a and last.b == b and last.live:
                contact.jn, contact.jt = last.jn, last.jt
                break
        new.append(contact)
    return len(points)


def find_contacts(robot: Robot, params, state: State) -> None:
    """dyn4j's ``World.detect`` after a step: each block against the ground under every
    terrain segment its bounding box spans (and that reaches above the box's bottom), then
    each pair of blocks that share no joint and are within reach; contacts to the ground
    first, block by block."""
    pos = state.pos
    xs, ys = robot.ground_x, robot.ground_y
    old, new = state.contacts, []
    state.touching = np.zeros(len(pos), dtype=bool)
    for p in range(len(pos)):
        two = block_polygon(pos, p)
        lo_x, hi_x, lo_y = two[:, 0].min(), two[:, 0].max(), two[:, 1].min()
        i = min(max(int(np.searchsorted(xs, lo_x, side="right")) - 1, 0), len(xs) - 2)
        while i < len(xs) - 1 and xs[i] < hi_x:
            if lo_y < max(ys[i], ys[i + 1]):
                one = ground_polygon(xs, ys, i)
                if add_contacts(robot, pos, old, new, p, -1, i, one, two, params.friction):
                    state.touching[p] = True
            i += 1
    reach = HALF_BLOCK * math.sqrt(2.0)  # a block's corner from its centre
    for a, b in robot.pair_ends:
        dx, dy = pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1]
        if dx * dx + dy * dy >= 4.0 * reach * reach:
            continue
        add_contacts(robot, pos, old, new, int(b), int(a), int(a), block_polygon(pos, a),
                     block_polygon(pos, b), params.block_friction)
    state.contacts = new


# the step -----------------------------------------------------------------------------------


def step(robot: Robot, params, state: State) -> None:
    """One physics step of dt = ``params.dt``, in dyn4j's order (module docstring)."""
    apply_gravity_and_damping(params, state.vel)
    set_up_contacts(robot, params, state)
    springs = set_up_springs(robot, params, state)
    ropes = set_up_ropes(robot, state)
    welds = set_up_welds(robot, state)
    for _ in range(params.velocity_iterations):
        solve_springs(robot, state, springs)
        solve_ropes(robot, state, ropes)
        solve_welds(robot, state, welds)
        solve_contacts(robot, state)
    move_bodies(params, state)
    for _ in range(params.position_iterations):
        # All three passes run before the test: each moves the bodies.
        contacts_held = fix_contacts(robot, state)
        ropes_held = fix_ropes(robot, state)
        welds_held = fix_welds(robot, state)
        if contacts_held and ropes_held and welds_held:
            break
    find_contacts(robot, params, state)


def control_step(robot: Robot, params, state: State) -> State:
    """One control step: ``params.substeps`` steps under the rest lengths ``state.rest``;
    returns the new state (``state`` is left as it was)."""
    state = copy.deepcopy(state)
    for _ in range(params.substeps):
        step(robot, params, state)
    return state
