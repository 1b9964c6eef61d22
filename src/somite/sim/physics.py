"""Physics of one robot: the original's rigid blocks, soft springs, rope limits and welds,
solved with sequential impulses, as dyn4j 3.3 (the engine under 2D-VSR-Sim) solves them.

Every function here works on one robot's arrays (its build, :class:`~somite.sim.robot.Robot`, and
its :class:`~somite.sim.state.BodyState`) and is called from the episode of
:mod:`somite.tasks.episode`; the CPU kernel (:mod:`somite.sim.group`) runs the joints' passes
and the move on a group's robots as vector lanes (:mod:`somite.sim.joint_lanes`) and the
contacts' passes on each robot's lane. A joint's arithmetic lives in one function of values
(``spring_terms``, ``spring_impulse``, ``pushed``, ``rope_fixed``, ``weld_fixed``, ``moved``,
...), which the passes over a robot's joints, and over a group's, call in order.
A robot's state is one rigid square block per voxel corner (four per voxel,
docs/original-system.md section 1.2): ``pos`` (P, 3) holds each block's centre and angle, ``vel``
(P, 3) its velocity and angular velocity.

One step (dyn4j's ``Island.solve``, docs/original-system.md section 1.1): gravity and damping change
the velocities; the springs (soft distance joints), rope limits, welds and contacts are set up from
the current positions and warm-started with last step's impulses; ``velocity_iterations`` passes
over them (joints first, then contacts) bring the velocities to what the constraints allow; the
positions move with the velocities; ``position_iterations`` passes push the rope limits, welds and
contacts back to their places (the soft springs get no position pass); and the contacts for the next
step are found. A contact holds its point still when Coulomb friction can, so a robot that does not
move its voxels stays where it is. Solving the constraints one after the other, not all at once from
one state, is what makes the welds between voxels and the ground couple neighbouring voxels as in
the original. The model and its parameters: docs/simulator.md; docs/decisions.md, "The
simulator"; BENCHMARKS.md, "Fidelity".
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .._jit import njit, uncounted
from . import step as order
from .config import BLOCK_SIDE, VOXEL_SIDE
from .step import implements
from .step import step as physics_step
from .trig import sincos

if TYPE_CHECKING:
    from .robot import Ground, Robot
    from .state import BodyState

HALF_BLOCK = BLOCK_SIDE / 2
BLOCK_REACH = HALF_BLOCK * math.sqrt(2.0)
"""Farthest a point of a block is from its centre [m]."""
CLEAR_REACH = 1.5 * HALF_BLOCK
"""[m] Above :data:`BLOCK_REACH` by a margin that rounding cannot cross: a block whose centre
is higher than this over the ground's top under the robot (:func:`ground_top`) has no corner
at or below it."""
RESTITUTION_SPEED = 1.0
"""[m/s] Slower impacts do not bounce (dyn4j's restitution velocity)."""
LINEAR_SLOP = 0.005
"""[m] Penetration and joint error the position passes leave alone (dyn4j's linear
tolerance)."""
ANGULAR_SLOP = 2.0 * math.pi / 180.0
"""[rad] The same for a weld's angle."""
MAX_CORRECTION = 0.2
"""[m] Largest position correction of one pass."""
BAUMGARTE = 0.2
"""Share of a contact's penetration that one position pass removes."""
MAX_TRANSLATION = 2.0
"""[m] Largest move of a body in one step."""
MAX_ROTATION = 0.5 * math.pi
"""[rad] Largest turn of a body in one step."""
WARM_START_DISTANCE = 0.01
"""[m] A contact point this close to last step's point of the same feature starts from its
impulses."""
CONDITION_LIMIT = 1000.0
"""A two-point contact whose 2x2 system is worse conditioned than this keeps its deeper point."""
GROUND_DEPTH = 50.0
"""[m] The ground under each terrain segment is a quadrilateral this deep below the segment's
lower end (the original's: below the terrain's lowest point; only its sides' height differs)."""

# Columns of a spring's work row (BodyState.spring).
J_RAX, J_RAY, J_RBX, J_RBY, J_NX, J_NY, J_MASS, J_GAMMA, J_BIAS, J_IMPULSE = range(10)
N_SPRING_COLUMNS = 10
# Columns of a rope's work row: direction, effective mass, impulse, active (1) or not (0).
R_NX, R_NY, R_MASS, R_IMPULSE, R_ACTIVE = range(5)
N_ROPE_COLUMNS = 5
# Columns of a weld's work row: the anchor's offset on the second body, the impulse (x, y, angle),
# then what its velocity passes solve with, set up once a step (:func:`weld_terms`): the 3x3
# effective-mass matrix (K00 .. K22), the cofactors of its first row and the inverse of its
# determinant.
(W_RBX, W_RBY, W_JX, W_JY, W_JZ, W_K00, W_K01, W_K02, W_K11, W_K12, W_K22, W_C00, W_C01, W_C02,
 W_DET) = range(15)
N_WELD_COLUMNS = 15
# Columns of a contact row. A contact pushes body A along the normal and body B (-1: the
# ground) the other way; LAX.. are the point in A's frame, LBX.. in B's (the world's for the
# ground). Rows of one contact pair (at most two points) are adjacent; COUNT is their number on
# the pair's first row and 0 on its second; LIVE is 0 for a point the solver dropped. On a
# two-point pair's first row, K00 .. I11: its 2x2 normal-impulse matrix and that matrix's
# inverse, set up once a step (:func:`start_contacts`).
(C_A, C_B, C_FEATURE, C_PX, C_PY, C_DEPTH, C_NX, C_NY, C_LAX, C_LAY, C_LBX, C_LBY, C_RAX,
 C_RAY, C_RBX, C_RBY, C_MASS_N, C_MASS_T, C_BOUNCE, C_JN, C_JT, C_JP, C_COUNT, C_LIVE,
 C_MU, C_K00, C_K01, C_K11, C_I00, C_I01, C_I11) = range(31)
N_CONTACT_COLUMNS = 31


@njit(inline="always")
def spring_length(kind: int, scale: float) -> float:
    """Length [m] of a spring of group ``kind`` in a voxel whose side is ``scale`` times the
    rest side (docs/original-system.md section 1.2): the side springs span the gap between two
    blocks, the cross springs join one block's outer corner to the next one's inner corner,
    the central springs join the centres of opposite blocks."""
    gap = VOXEL_SIDE * scale - 2.0 * BLOCK_SIDE
    if kind == 0:
        return gap
    if kind == 1:
        return math.sqrt(BLOCK_SIDE * BLOCK_SIDE + gap * gap)
    return (VOXEL_SIDE * scale - BLOCK_SIDE) * math.sqrt(2.0)


@uncounted
def set_rest_lengths(n_springs, kind, owner, actuation, contract, expand, rest):
    """``rest``: the rest length of each spring for its voxel's ``actuation`` (V,): from its
    group's rest length towards its length in a voxel of side ``contract`` x 3 m at +1, of
    ``expand`` x 3 m at -1, linearly."""
    # The three lengths of each of the three groups, once a call rather than once a spring.
    r0 = (spring_length(0, 1.0), spring_length(1, 1.0), spring_length(2, 1.0))
    shorter = (r0[0] - spring_length(0, contract), r0[1] - spring_length(1, contract),
               r0[2] - spring_length(2, contract))
    longer = (spring_length(0, expand) - r0[0], spring_length(1, expand) - r0[1],
              spring_length(2, expand) - r0[2])
    for s in range(n_springs):
        a = min(1.0, max(-1.0, actuation[owner[s]]))
        k = kind[s]
        if a >= 0.0:
            rest[s] = r0[k] - shorter[k] * a
        else:
            rest[s] = r0[k] + longer[k] * (-a)


@njit(inline="always")
def turn(n_points, pos, cos, sin):
    """Each body's rotation, from its angle."""
    for p in range(n_points):
        cos[p], sin[p] = sincos(pos[p, 2])


@njit
def rotated(ox, oy, c, s):
    """Offset (ox, oy) in a body's frame, turned into the world's (c, s: the body's cosine and
    sine)."""
    return c * ox - s * oy, s * ox + c * oy


@njit(inline="always")
def turned(p, ox, oy, cos, sin):
    """Offset (ox, oy) in body p's frame, turned into the world's."""
    return rotated(ox, oy, cos[p], sin[p])


@njit(inline="always")
def world_point(p, ox, oy, pos, cos, sin):
    """World position of offset (ox, oy) of body p."""
    return (pos[p, 0] + cos[p] * ox - sin[p] * oy, pos[p, 1] + sin[p] * ox + cos[p] * oy)


# The joints' arithmetic is in functions of values (``pushed``, ``relative``, ``spring_terms``,
# ``spring_impulse``, ...), which the passes here call between their loads and stores, one robot
# at a time, and :mod:`somite.sim.joint_lanes` calls for W robots at once: one definition, so
# that both give the same numbers bit for bit. Their choices are written ``x if c else y`` over
# values computed beforehand, so that the compiler can make them selects, not branches, and
# vectorise them across robots.


@njit
def pushed(a0, a1, a2, b0, b1, b2, rax, ray, rbx, rby, jx, jy, ima, iia, imb, iib):
    """States (velocity or position) of bodies a and b after impulse (jx, jy) on a at offset
    ra and its opposite on b at rb (ima, iia: a's inverse mass and inertia)."""
    return (a0 + jx * ima, a1 + jy * ima, a2 + iia * (rax * jy - ray * jx),
            b0 - jx * imb, b1 - jy * imb, b2 - iib * (rbx * jy - rby * jx))


@njit
def relative(a0, a1, a2, b0, b1, b2, rax, ray, rbx, rby):
    """Velocity of body a's point ra relative to body b's point rb."""
    return a0 - a2 * ray - (b0 - b2 * rby), a1 + a2 * rax - (b1 + b2 * rbx)


@njit(inline="always")
def push(vel, a, b, r, j, masses):
    """Impulse ``j`` = (jx, jy) on body a at offset ra, its opposite on body b at rb (b < 0:
    the ground); ``r`` = (rax, ray, rbx, rby), ``masses`` = (inv_mass, inv_inertia). Also moves
    positions: ``vel`` may be ``pos``, the same arithmetic."""
    rax, ray, rbx, rby = r
    jx, jy = j
    inv_mass, inv_inertia = masses
    vel[a, 0] += jx * inv_mass[a]
    vel[a, 1] += jy * inv_mass[a]
    vel[a, 2] += inv_inertia[a] * (rax * jy - ray * jx)
    if b >= 0:
        vel[b, 0] -= jx * inv_mass[b]
        vel[b, 1] -= jy * inv_mass[b]
        vel[b, 2] -= inv_inertia[b] * (rbx * jy - rby * jx)


@njit(inline="always")
def relative_velocity(vel, a, b, rax, ray, rbx, rby):
    """Velocity of body a's point ra relative to body b's point rb (b < 0: the ground)."""
    if b >= 0:
        return relative(vel[a, 0], vel[a, 1], vel[a, 2], vel[b, 0], vel[b, 1], vel[b, 2], rax,
                        ray, rbx, rby)
    return vel[a, 0] - vel[a, 2] * ray, vel[a, 1] + vel[a, 2] * rax


@njit  # called, as a lane pass calls it for every lane (LLVM inlines it)
def unit(x, y):
    """(x, y) scaled to length 1, and its length; a vector shorter than LINEAR_SLOP has no
    direction (dyn4j's rule), so it gives (0, 0)."""
    length = math.sqrt(x * x + y * y)
    ux = x / length
    uy = y / length
    short = length < LINEAR_SLOP
    return 0.0 if short else ux, 0.0 if short else uy, length


@njit
def spring_terms(pa0, pa1, pb0, pb1, rax, ray, rbx, rby, rest, ima, iia, imb, iib, dt, omega,
                 damping_ratio):
    """A spring's direction (nx, ny), effective mass, softness gamma and bias for this step,
    from its ends' positions and anchor offsets (a damped spring as a soft constraint: its
    stiffness and damping from the frequency and damping ratio and the effective mass along
    it, as dyn4j's DistanceJoint)."""
    nx, ny, length = unit(pa0 + rax - pb0 - rbx, pa1 + ray - pb1 - rby)
    cra = rax * ny - ray * nx
    crb = rbx * ny - rby * nx
    w = ima + iia * cra * cra + imb + iib * crb * crb
    inverse = 1.0 / w
    mass = inverse if w > 0.0 else 0.0
    stiffness = mass * omega * omega
    damping = 2.0 * mass * damping_ratio * omega
    gamma = dt * (damping + dt * stiffness)
    inverse = 1.0 / gamma
    gamma = inverse if gamma > 0.0 else 0.0
    w += gamma
    inverse = 1.0 / w
    return (nx, ny, inverse if w > 0.0 else 0.0, gamma,
            (length - rest) * dt * stiffness * gamma)


@njit
def spring_impulse(rax, ray, rbx, rby, nx, ny, mass, bias, gamma, impulse, a0, a1, a2, b0, b1,
                   b2):
    """One velocity pass's impulse of a spring on its bodies' velocities a0.. and b0.."""
    vx, vy = relative(a0, a1, a2, b0, b1, b2, rax, ray, rbx, rby)
    return -mass * (nx * vx + ny * vy + bias + gamma * impulse)


@njit(inline="always")
def push_pair(vel, a, b, r, j, m):
    """:func:`pushed` on the rows a and b of ``vel``: ``r`` = (rax, ray, rbx, rby), ``j`` =
    (jx, jy), ``m`` = (ima, iia, imb, iib)."""
    rax, ray, rbx, rby = r
    jx, jy = j
    ima, iia, imb, iib = m
    (vel[a, 0], vel[a, 1], vel[a, 2], vel[b, 0], vel[b, 1], vel[b, 2]) = pushed(
        vel[a, 0], vel[a, 1], vel[a, 2], vel[b, 0], vel[b, 1], vel[b, 2], rax, ray, rbx, rby, jx,
        jy, ima, iia, imb, iib)


@njit(inline="always")
def spring_setup(s, a, b, robot, state, pos, vel, terms):
    """Set up spring s (ends a, b) for this step (:func:`spring_terms`; ``terms``: dt, omega,
    damping ratio) and apply last step's impulse."""
    anchor, rest, work, cos, sin = robot.anchor, state.rest, state.spring, state.cos, \
        state.sin
    inv_mass, inv_inertia = robot.inv_mass, robot.inv_inertia
    dt, omega, damping_ratio = terms
    ima, iia, imb, iib = inv_mass[a], inv_inertia[a], inv_mass[b], inv_inertia[b]
    rax, ray = turned(a, anchor[s, 0], anchor[s, 1], cos, sin)
    rbx, rby = turned(b, anchor[s, 2], anchor[s, 3], cos, sin)
    nx, ny, mass, gamma, bias = spring_terms(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1], rax,
                                             ray, rbx, rby, rest[s], ima, iia, imb, iib, dt,
                                             omega, damping_ratio)
    work[s, J_RAX] = rax
    work[s, J_RAY] = ray
    work[s, J_RBX] = rbx
    work[s, J_RBY] = rby
    work[s, J_NX] = nx
    work[s, J_NY] = ny
    work[s, J_MASS] = mass
    work[s, J_GAMMA] = gamma
    work[s, J_BIAS] = bias
    j = work[s, J_IMPULSE]
    push_pair(vel, a, b, (rax, ray, rbx, rby), (nx * j, ny * j), (ima, iia, imb, iib))


@njit(inline="always")
def spring_solve(s, a, b, work, vel, inv_mass, inv_inertia):
    """One velocity pass over spring s (ends a, b)."""
    rax = work[s, J_RAX]
    ray = work[s, J_RAY]
    rbx = work[s, J_RBX]
    rby = work[s, J_RBY]
    nx = work[s, J_NX]
    ny = work[s, J_NY]
    j = spring_impulse(rax, ray, rbx, rby, nx, ny, work[s, J_MASS], work[s, J_BIAS],
                       work[s, J_GAMMA], work[s, J_IMPULSE], vel[a, 0], vel[a, 1], vel[a, 2],
                       vel[b, 0], vel[b, 1], vel[b, 2])
    work[s, J_IMPULSE] += j
    push_pair(vel, a, b, (rax, ray, rbx, rby), (nx * j, ny * j),
              (inv_mass[a], inv_inertia[a], inv_mass[b], inv_inertia[b]))


@njit(inline="always")
def start_springs(robot, state, pos, vel, params):
    """Set up the soft springs for this step (:func:`spring_setup`)."""
    ends = robot.ends
    omega = 2.0 * math.pi * params.spring_hz
    for s in range(robot.n_springs):
        spring_setup(s, ends[s, 0], ends[s, 1], robot, state, pos, vel,
                     (params.dt, omega, params.damping_ratio))


@njit(inline="always")
def solve_springs(robot, state, vel):
    ends = robot.ends
    for s in range(robot.n_springs):
        spring_solve(s, ends[s, 0], ends[s, 1], state.spring, vel, robot.inv_mass,
                     robot.inv_inertia)


@njit
def rope_impulse(nx, ny, mass, a0, a1, b0, b1):
    """One velocity pass's impulse of an active rope limit on its bodies' velocities."""
    return -mass * (nx * (a0 - b0) + ny * (a1 - b1))


@njit(inline="always")
def rope_setup(r, a, b, work, pos, vel, inv_mass, inv_inertia):
    """Rope limit r between the centres of a voxel's adjacent blocks a, b: active while the
    blocks are closer than one block side (they would overlap), as dyn4j's RopeJoint with a
    lower limit only; while active, the limit holds the distance in both directions."""
    nx, ny, length = unit(pos[a, 0] - pos[b, 0], pos[a, 1] - pos[b, 1])
    if length < BLOCK_SIDE:
        work[r, R_NX] = nx
        work[r, R_NY] = ny
        work[r, R_MASS] = 1.0 / (inv_mass[a] + inv_mass[b])
        work[r, R_ACTIVE] = 1.0
        j = work[r, R_IMPULSE]
        push_pair(vel, a, b, (0.0, 0.0, 0.0, 0.0), (nx * j, ny * j),
                  (inv_mass[a], inv_inertia[a], inv_mass[b], inv_inertia[b]))
    else:
        work[r, R_ACTIVE] = 0.0
        work[r, R_IMPULSE] = 0.0


@njit(inline="always")
def rope_solve(r, a, b, work, vel, inv_mass, inv_inertia):
    if work[r, R_ACTIVE] == 0.0:
        return
    nx = work[r, R_NX]
    ny = work[r, R_NY]
    j = rope_impulse(nx, ny, work[r, R_MASS], vel[a, 0], vel[a, 1], vel[b, 0], vel[b, 1])
    work[r, R_IMPULSE] += j
    push_pair(vel, a, b, (0.0, 0.0, 0.0, 0.0), (nx * j, ny * j),
              (inv_mass[a], inv_inertia[a], inv_mass[b], inv_inertia[b]))


@njit
def rope_fixed(pa0, pa1, pb0, pb1, ima, imb):
    """A rope limit's position pass on its bodies' centres (a at pa, b at pb): the impulse
    (jx, jy) on a (its opposite on b), whether the limit is slack (then nothing moves) and
    whether it holds."""
    dx = pa0 - pb0
    dy = pa1 - pb1
    length = math.sqrt(dx * dx + dy * dy)
    slack = length >= BLOCK_SIDE
    nx = dx / length if length > 0.0 else dx
    ny = dy / length if length > 0.0 else dy
    error = max(length - BLOCK_SIDE, -MAX_CORRECTION)
    j = -error / (ima + imb)
    return nx * j, ny * j, slack, slack or not -error >= LINEAR_SLOP


@njit(inline="always")
def rope_fix(a, b, pos, inv_mass, inv_inertia) -> bool:
    """One position pass over the rope limit between a and b; whether it holds."""
    jx, jy, slack, held = rope_fixed(pos[a, 0], pos[a, 1], pos[b, 0], pos[b, 1], inv_mass[a],
                                     inv_mass[b])
    if not slack:
        push(pos, a, b, (0.0, 0.0, 0.0, 0.0), (jx, jy), (inv_mass, inv_inertia))
    return held


@njit(inline="always")
def start_ropes(robot, state, pos, vel):
    """Set up the rope limits for this step (:func:`rope_setup`)."""
    ends = robot.rope_ends
    for r in range(robot.n_ropes):
        rope_setup(r, ends[r, 0], ends[r, 1], state.rope, pos, vel, robot.inv_mass,
                   robot.inv_inertia)


@njit(inline="always")
def solve_ropes(robot, state, vel):
    ends = robot.rope_ends
    for r in range(robot.n_ropes):
        rope_solve(r, ends[r, 0], ends[r, 1], state.rope, vel, robot.inv_mass,
                   robot.inv_inertia)


@njit(inline="always")
def fix_ropes(robot, pos) -> bool:
    """One position pass over the active rope limits; whether they all hold."""
    ends = robot.rope_ends
    held = True
    for r in range(robot.n_ropes):
        if not rope_fix(ends[r, 0], ends[r, 1], pos, robot.inv_mass, robot.inv_inertia):
            held = False
    return held


@njit(inline="always")
def cofactors33(a00, a01, a02, a11, a12, a22):
    """What :func:`solve33` needs of the symmetric matrix A alone: the cofactors of its first
    row and the inverse of its determinant (0 if A is singular)."""
    c00 = a11 * a22 - a12 * a12
    c01 = a01 * a22 - a12 * a02
    c02 = a01 * a12 - a11 * a02
    det = a00 * c00 - a01 * c01 + a02 * c02
    inverse = 1.0 / det
    return c00, c01, c02, inverse if det != 0.0 else det


@njit
def solved33(a00, a01, a02, a11, a12, a22, c00, c01, c02, det, bx, by, bz):
    """x of the symmetric system A x = b, given A's :func:`cofactors33` (Cramer's rule)."""
    x = det * (bx * c00 - a01 * (by * a22 - a12 * bz) + a02 * (by * a12 - a11 * bz))
    y = det * (a00 * (by * a22 - bz * a12) - bx * c01 + a02 * (a01 * bz - by * a02))
    z = det * (a00 * (a11 * bz - a12 * by) - a01 * (a01 * bz - by * a02) + bx * c02)
    return x, y, z


@njit(inline="always")
def solve33(a00, a01, a02, a11, a12, a22, bx, by, bz):
    """x of the symmetric system A x = b (Cramer's rule; 0 if A is singular)."""
    c00, c01, c02, det = cofactors33(a00, a01, a02, a11, a12, a22)
    return solved33(a00, a01, a02, a11, a12, a22, c00, c01, c02, det, bx, by, bz)


@njit(inline="always")
def weld_matrix(ima, iia, imb, iib, rbx, rby):
    """The weld's 3x3 effective-mass matrix (its anchor sits at the first body's centre)."""
    return (ima + imb + rby * rby * iib, -rby * rbx * iib, -rby * iib,
            ima + imb + rbx * rbx * iib, rbx * iib, iia + iib)


@njit
def weld_pushed(a0, a1, a2, b0, b1, b2, rbx, rby, jx, jy, jz, ima, iia, imb, iib):
    """States of bodies a and b after a weld's impulse (jx, jy, jz) (its anchor at a's
    centre, rb from b's)."""
    return (a0 + jx * ima, a1 + jy * ima, a2 + iia * jz,
            b0 - jx * imb, b1 - jy * imb, b2 - iib * (rbx * jy - rby * jx + jz))


@njit
def weld_terms(ima, iia, imb, iib, rbx, rby):
    """What a weld's velocity passes solve with, from its set-up alone: its
    :func:`weld_matrix` and that matrix's :func:`cofactors33` (K00 .. K22, C00, C01, C02,
    DET). Set up once a step rather than in each pass: the same expressions, so the same bits,
    without a division a pass."""
    k00, k01, k02, k11, k12, k22 = weld_matrix(ima, iia, imb, iib, rbx, rby)
    c00, c01, c02, det = cofactors33(k00, k01, k02, k11, k12, k22)
    return k00, k01, k02, k11, k12, k22, c00, c01, c02, det


@njit
def weld_impulse(rbx, rby, k, a0, a1, a2, b0, b1, b2):
    """One velocity pass's impulse (x, y, angle) of a weld on its bodies' velocities; ``k``:
    its :func:`weld_terms`."""
    k00, k01, k02, k11, k12, k22, c00, c01, c02, det = k
    vx, vy = relative(a0, a1, a2, b0, b1, b2, 0.0, 0.0, rbx, rby)
    return solved33(k00, k01, k02, k11, k12, k22, c00, c01, c02, det, -vx, -vy, -(a2 - b2))


@njit(inline="always")
def weld_push(state, a, b, rb, j, masses):
    """:func:`weld_pushed` on the rows a and b of ``state``: ``rb`` = (rbx, rby), ``j`` =
    (jx, jy, jz), ``masses`` = (inv_mass, inv_inertia)."""
    rbx, rby = rb
    jx, jy, jz = j
    inv_mass, inv_inertia = masses
    (state[a, 0], state[a, 1], state[a, 2], state[b, 0], state[b, 1], state[b, 2]) = \
        weld_pushed(state[a, 0], state[a, 1], state[a, 2], state[b, 0], state[b, 1],
                    state[b, 2], rbx, rby, jx, jy, jz, inv_mass[a], inv_inertia[a], inv_mass[b],
                    inv_inertia[b])


@njit(inline="always")
def weld_setup(q, a, b, robot, state, vel):
    anchor, work = robot.weld_anchor, state.weld
    rbx, rby = turned(b, anchor[q, 0], anchor[q, 1], state.cos, state.sin)
    work[q, W_RBX] = rbx
    work[q, W_RBY] = rby
    inv_mass, inv_inertia = robot.inv_mass, robot.inv_inertia
    w = work[q]
    (w[W_K00], w[W_K01], w[W_K02], w[W_K11], w[W_K12], w[W_K22], w[W_C00], w[W_C01], w[W_C02],
     w[W_DET]) = weld_terms(inv_mass[a], inv_inertia[a], inv_mass[b], inv_inertia[b], rbx, rby)
    weld_push(vel, a, b, (rbx, rby), (work[q, W_JX], work[q, W_JY], work[q, W_JZ]),
              (inv_mass, inv_inertia))


@njit(inline="always")
def weld_solve(q, a, b, work, vel, inv_mass, inv_inertia):
    rbx = work[q, W_RBX]
    rby = work[q, W_RBY]
    w = work[q]
    jx, jy, jz = weld_impulse(rbx, rby, (w[W_K00], w[W_K01], w[W_K02], w[W_K11], w[W_K12],
                                         w[W_K22], w[W_C00], w[W_C01], w[W_C02], w[W_DET]),
                              vel[a, 0], vel[a, 1], vel[a, 2], vel[b, 0], vel[b, 1], vel[b, 2])
    work[q, W_JX] += jx
    work[q, W_JY] += jy
    work[q, W_JZ] += jz
    weld_push(vel, a, b, (rbx, rby), (jx, jy, jz), (inv_mass, inv_inertia))


@njit
def weld_fixed(pa0, pa1, pa2, pb0, pb1, pb2, rbx, rby, ima, iia, imb, iib):
    """A weld's position pass (the whole error at once, as dyn4j's rigid WeldJoint) on its
    bodies' positions (rb: its anchor's offset from b, turned): the impulse (jx, jy, jz) on a
    (its opposite on b, :func:`weld_pushed`) and whether the weld holds."""
    cx = pa0 - pb0 - rbx
    cy = pa1 - pb1 - rby
    angle = pa2 - pb2
    angle = angle + 2.0 * math.pi if angle < -math.pi else angle
    angle = angle - 2.0 * math.pi if angle > math.pi else angle
    k00, k01, k02, k11, k12, k22 = weld_matrix(ima, iia, imb, iib, rbx, rby)
    jx, jy, jz = solve33(k00, k01, k02, k11, k12, k22, -cx, -cy, -angle)
    return jx, jy, jz, not (math.sqrt(cx * cx + cy * cy) > LINEAR_SLOP
                             or abs(angle) > ANGULAR_SLOP)


@njit(inline="always")
def weld_fix(q, a, b, robot, pos, cos, sin) -> bool:
    """One position pass over weld q between a and b (:func:`weld_fixed`); whether it holds.
    Updates the rotations it changes."""
    anchor, inv_mass, inv_inertia = robot.weld_anchor, robot.inv_mass, robot.inv_inertia
    rbx, rby = turned(b, anchor[q, 0], anchor[q, 1], cos, sin)
    jx, jy, jz, held = weld_fixed(pos[a, 0], pos[a, 1], pos[a, 2], pos[b, 0], pos[b, 1],
                                  pos[b, 2], rbx, rby, inv_mass[a], inv_inertia[a],
                                  inv_mass[b], inv_inertia[b])
    weld_push(pos, a, b, (rbx, rby), (jx, jy, jz), (inv_mass, inv_inertia))
    cos[a], sin[a] = sincos(pos[a, 2])
    cos[b], sin[b] = sincos(pos[b, 2])
    return held


@njit(inline="always")
def start_welds(robot, state, vel):
    ends = robot.weld_ends
    for q in range(robot.n_welds):
        weld_setup(q, ends[q, 0], ends[q, 1], robot, state, vel)


@njit(inline="always")
def solve_welds(robot, state, vel):
    ends = robot.weld_ends
    for q in range(robot.n_welds):
        weld_solve(q, ends[q, 0], ends[q, 1], state.weld, vel, robot.inv_mass,
                   robot.inv_inertia)


@njit(inline="always")
def fix_welds(robot, pos, cos, sin) -> bool:
    """One position pass over the welds (:func:`weld_fix`); whether they all hold."""
    ends = robot.weld_ends
    held = True
    for q in range(robot.n_welds):
        if not weld_fix(q, ends[q, 0], ends[q, 1], robot, pos, cos, sin):
            held = False
    return held


@uncounted
def start_contacts(robot, state, pos, vel, params):
    """Set up this step's contacts (found at the end of the last step) and apply their
    warm-start impulses.

    This and :func:`find_contacts`, called once a step, are compiled once and called rather
    than inlined like the other passes: inlined into both :func:`advance` and the grouped
    kernel, they made the first compile of both 1.8x as long (BENCHMARKS.md)."""
    c = state.contacts
    inv_mass = robot.inv_mass
    inv_inertia = robot.inv_inertia
    n = state.counts[0]
    for k in range(n):
        a = int(c[k, C_A])
        b = int(c[k, C_B])
        nx = c[k, C_NX]
        ny = c[k, C_NY]
        rax = c[k, C_PX] - pos[a, 0]
        ray = c[k, C_PY] - pos[a, 1]
        rbx = rby = 0.0
        if b >= 0:
            rbx = c[k, C_PX] - pos[b, 0]
            rby = c[k, C_PY] - pos[b, 1]
        c[k, C_RAX] = rax
        c[k, C_RAY] = ray
        c[k, C_RBX] = rbx
        c[k, C_RBY] = rby
        ima = inv_mass[a]
        iia = inv_inertia[a]
        imb = inv_mass[b] if b >= 0 else 0.0
        iib = inv_inertia[b] if b >= 0 else 0.0
        rna = rax * ny - ray * nx
        rnb = rbx * ny - rby * nx
        c[k, C_MASS_N] = 1.0 / (ima + imb + iia * rna * rna + iib * rnb * rnb)
        rta = rax * (-nx) - ray * ny
        rtb = rbx * (-nx) - rby * ny
        c[k, C_MASS_T] = 1.0 / (ima + imb + iia * rta * rta + iib * rtb * rtb)
        vx, vy = relative_velocity(vel, a, b, rax, ray, rbx, rby)
        vn = vx * nx + vy * ny
        c[k, C_BOUNCE] = -params.restitution * vn if vn < -RESTITUTION_SPEED else 0.0
        c[k, C_JP] = 0.0
    for k in range(n):
        if c[k, C_COUNT] != 2.0:
            continue
        a = int(c[k, C_A])
        b = int(c[k, C_B])
        k00, k01, k11 = pair_matrix(c, k, a, b, inv_mass, inv_inertia)
        det = k00 * k11 - k01 * k01
        if not k00 * k00 < CONDITION_LIMIT * det:
            drop = k + 1 if c[k, C_DEPTH] > c[k + 1, C_DEPTH] else k
            c[drop, C_LIVE] = 0.0
        # What the block solver (solve_pair) needs of the pair, once a step, not once a pass.
        c[k, C_K00] = k00
        c[k, C_K01] = k01
        c[k, C_K11] = k11
        c[k, C_I00] = k11 / det
        c[k, C_I01] = -k01 / det
        c[k, C_I11] = k00 / det
    for k in range(n):
        if c[k, C_LIVE] == 0.0:
            continue
        a = int(c[k, C_A])
        b = int(c[k, C_B])
        nx = c[k, C_NX]
        ny = c[k, C_NY]
        jn = c[k, C_JN]
        jt = c[k, C_JT]
        push(vel, a, b, (c[k, C_RAX], c[k, C_RAY], c[k, C_RBX], c[k, C_RBY]),
             (nx * jn + ny * jt, ny * jn - nx * jt), (inv_mass, inv_inertia))


@njit(inline="always")
def pair_matrix(c, k, a, b, inv_mass, inv_inertia):
    """The 2x2 normal-impulse matrix of the contact pair at rows k, k + 1."""
    nx = c[k, C_NX]
    ny = c[k, C_NY]
    m = inv_mass[a] + (inv_mass[b] if b >= 0 else 0.0)
    iia = inv_inertia[a]
    iib = inv_inertia[b] if b >= 0 else 0.0
    r1a = c[k, C_RAX] * ny - c[k, C_RAY] * nx
    r1b = c[k, C_RBX] * ny - c[k, C_RBY] * nx
    r2a = c[k + 1, C_RAX] * ny - c[k + 1, C_RAY] * nx
    r2b = c[k + 1, C_RBX] * ny - c[k + 1, C_RBY] * nx
    return (m + iia * r1a * r1a + iib * r1b * r1b, m + iia * r1a * r2a + iib * r1b * r2b,
            m + iia * r2a * r2a + iib * r2b * r2b)


@njit(inline="always")
def solve_normal(c, k, vel, inv_mass, inv_inertia):
    a = int(c[k, C_A])
    b = int(c[k, C_B])
    nx = c[k, C_NX]
    ny = c[k, C_NY]
    vx, vy = relative_velocity(vel, a, b, c[k, C_RAX], c[k, C_RAY], c[k, C_RBX], c[k, C_RBY])
    j = -c[k, C_MASS_N] * (vx * nx + vy * ny - c[k, C_BOUNCE])
    j0 = c[k, C_JN]
    c[k, C_JN] = max(j0 + j, 0.0)
    j = c[k, C_JN] - j0
    push(vel, a, b, (c[k, C_RAX], c[k, C_RAY], c[k, C_RBX], c[k, C_RBY]), (nx * j, ny * j),
         (inv_mass, inv_inertia))


@njit(inline="always")
def solve_pair(c, k, vel, inv_mass, inv_inertia):
    """Both normal impulses of a two-point contact at once (the block solver of Box2D and
    dyn4j: the first of the four cases, both pushing, one pushing, neither, that holds)."""
    a = int(c[k, C_A])
    b = int(c[k, C_B])
    nx = c[k, C_NX]
    ny = c[k, C_NY]
    k00 = c[k, C_K00]
    k01 = c[k, C_K01]
    k11 = c[k, C_K11]
    i00 = c[k, C_I00]
    i01 = c[k, C_I01]
    i11 = c[k, C_I11]
    a1 = c[k, C_JN]
    a2 = c[k + 1, C_JN]
    v1x, v1y = relative_velocity(vel, a, b, c[k, C_RAX], c[k, C_RAY], c[k, C_RBX], c[k, C_RBY])
    v2x, v2y = relative_velocity(vel, a, b, c[k + 1, C_RAX], c[k + 1, C_RAY], c[k + 1, C_RBX],
                                 c[k + 1, C_RBY])
    b1 = v1x * nx + v1y * ny - c[k, C_BOUNCE] - (k00 * a1 + k01 * a2)
    b2 = v2x * nx + v2y * ny - c[k + 1, C_BOUNCE] - (k01 * a1 + k11 * a2)
    x1 = -(i00 * b1 + i01 * b2)
    x2 = -(i01 * b1 + i11 * b2)
    if not (x1 >= 0.0 and x2 >= 0.0):
        x1 = -c[k, C_MASS_N] * b1
        x2 = 0.0
        if not (x1 >= 0.0 and k01 * x1 + b2 >= 0.0):
            x1 = 0.0
            x2 = -c[k + 1, C_MASS_N] * b2
            if not (x2 >= 0.0 and k01 * x2 + b1 >= 0.0):
                x1 = x2 = 0.0
                if not (b1 >= 0.0 and b2 >= 0.0):
                    return
    d1 = x1 - a1
    d2 = x2 - a2
    push(vel, a, b, (c[k, C_RAX], c[k, C_RAY], c[k, C_RBX], c[k, C_RBY]), (nx * d1, ny * d1),
         (inv_mass, inv_inertia))
    push(vel, a, b, (c[k + 1, C_RAX], c[k + 1, C_RAY], c[k + 1, C_RBX], c[k + 1, C_RBY]),
         (nx * d2, ny * d2), (inv_mass, inv_inertia))
    c[k, C_JN] = x1
    c[k + 1, C_JN] = x2


@njit(inline="always")
def solve_contacts(robot, state, vel):
    """One velocity pass over the contacts, pair by pair: friction first (within mu times the
    normal impulse), then the normal impulses."""
    c = state.contacts
    inv_mass = robot.inv_mass
    inv_inertia = robot.inv_inertia
    n = state.counts[0]
    k = 0
    while k < n:
        count = int(c[k, C_COUNT])
        for i in range(k, k + count):
            if c[i, C_LIVE] == 0.0:
                continue
            a = int(c[i, C_A])
            b = int(c[i, C_B])
            tx = c[i, C_NY]
            ty = -c[i, C_NX]
            vx, vy = relative_velocity(vel, a, b, c[i, C_RAX], c[i, C_RAY], c[i, C_RBX],
                                       c[i, C_RBY])
            j = -c[i, C_MASS_T] * (vx * tx + vy * ty)
            limit = c[i, C_MU] * c[i, C_JN]
            j0 = c[i, C_JT]
            c[i, C_JT] = max(-limit, min(j0 + j, limit))
            j = c[i, C_JT] - j0
            push(vel, a, b, (c[i, C_RAX], c[i, C_RAY], c[i, C_RBX], c[i, C_RBY]),
                 (tx * j, ty * j), (inv_mass, inv_inertia))
        if count == 2 and c[k, C_LIVE] != 0.0 and c[k + 1, C_LIVE] != 0.0:
            solve_pair(c, k, vel, inv_mass, inv_inertia)
        else:
            for i in range(k, k + count):
                if c[i, C_LIVE] != 0.0:
                    solve_normal(c, i, vel, inv_mass, inv_inertia)
        k += count


@njit(inline="always")
def fix_contacts(robot, state, pos, cos, sin) -> bool:
    """One position pass over the contacts: each pushes its bodies apart by a share
    (BAUMGARTE) of its penetration beyond LINEAR_SLOP; whether none is deeper than three
    times LINEAR_SLOP. ``pos``, ``cos``, ``sin``: the bodies' positions and rotations."""
    c = state.contacts
    inv_mass = robot.inv_mass
    inv_inertia = robot.inv_inertia
    deepest = 0.0
    for k in range(state.counts[0]):
        if c[k, C_LIVE] == 0.0:
            continue
        a = int(c[k, C_A])
        b = int(c[k, C_B])
        nx = c[k, C_NX]
        ny = c[k, C_NY]
        rax, ray = turned(a, c[k, C_LAX], c[k, C_LAY], cos, sin)
        px = pos[a, 0] + rax
        py = pos[a, 1] + ray
        rbx = rby = 0.0
        if b >= 0:
            rbx, rby = turned(b, c[k, C_LBX], c[k, C_LBY], cos, sin)
            qx = pos[b, 0] + rbx
            qy = pos[b, 1] + rby
        else:
            qx = c[k, C_LBX]
            qy = c[k, C_LBY]
        separation = (px - qx) * nx + (py - qy) * ny - c[k, C_DEPTH]
        deepest = min(deepest, separation)
        correction = BAUMGARTE * min(max(separation + LINEAR_SLOP, -MAX_CORRECTION), 0.0)
        rna = rax * ny - ray * nx
        rnb = rbx * ny - rby * nx
        w = inv_mass[a] + inv_inertia[a] * rna * rna
        if b >= 0:
            w += inv_mass[b] + inv_inertia[b] * rnb * rnb
        j = -correction / w
        j0 = c[k, C_JP]
        c[k, C_JP] = max(j0 + j, 0.0)
        j = c[k, C_JP] - j0
        push(pos, a, b, (rax, ray, rbx, rby), (nx * j, ny * j), (inv_mass, inv_inertia))
        cos[a], sin[a] = sincos(pos[a, 2])
        if b >= 0:
            cos[b], sin[b] = sincos(pos[b, 2])
    return deepest >= -3.0 * LINEAR_SLOP


@njit(inline="always")
def segment_near(xs, n, x, guess) -> int:
    """Index of the segment under x, walking from ``guess`` (a point moves little per step)."""
    i = min(max(guess, 0), n - 2)
    while i > 0 and x < xs[i]:
        i -= 1
    while i < n - 2 and x >= xs[i + 1]:
        i += 1
    return i


@njit(inline="always")
def ground_top(xs, ys, n, pos, n_points, guess) -> float:
    """The highest terrain vertex of the segments under the robot's bodies (their centres' x
    span widened by :data:`CLEAR_REACH`), or inf where that span leaves the terrain (the
    ground's height is then extrapolated): the tests it allows leave out only what exact ones
    would leave out."""
    x_lo = x_hi = pos[0, 0]
    for p in range(1, n_points):
        x_lo = min(x_lo, pos[p, 0])
        x_hi = max(x_hi, pos[p, 0])
    x_lo -= CLEAR_REACH
    x_hi += CLEAR_REACH
    if not (x_lo >= xs[0] and x_hi < xs[n - 1]):
        return math.inf
    i = segment_near(xs, n, x_lo, guess)
    top = ys[i]
    while i < n - 1 and xs[i] <= x_hi:
        top = max(top, ys[i + 1])
        i += 1
    return top


@uncounted
def ground_height(xs, ys, n, x, guess) -> float:
    """Height [m] of the terrain at x (``guess``: a segment index near x)."""
    i = segment_near(xs, n, x, guess)
    t = (x - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + t * (ys[i + 1] - ys[i])


@njit(inline="always")
def block_polygon(p, pos, cos, sin, poly):
    """Body p's square into ``poly`` (4, 4): vertices x, y and the outward normal of the edge
    from each vertex to the next, counter-clockwise from the lower left (in its own frame)."""
    block_vertices(p, pos, cos, sin, poly)
    block_normals(p, cos, sin, poly)


@njit(inline="always")
def block_vertices(p, pos, cos, sin, poly):
    """:func:`block_polygon`'s vertices alone (columns 0, 1)."""
    for j in range(4):
        lx = HALF_BLOCK if j == 1 or j == 2 else -HALF_BLOCK
        ly = HALF_BLOCK if j >= 2 else -HALF_BLOCK
        poly[j, 0] = pos[p, 0] + cos[p] * lx - sin[p] * ly
        poly[j, 1] = pos[p, 1] + sin[p] * lx + cos[p] * ly


@njit(inline="always")
def block_normals(p, cos, sin, poly):
    """:func:`block_polygon`'s edge normals alone (columns 2, 3)."""
    for j in range(4):
        nx = 0.0
        ny = 0.0
        if j == 0:
            ny = -1.0
        elif j == 1:
            nx = 1.0
        elif j == 2:
            ny = 1.0
        else:
            nx = -1.0
        poly[j, 2] = cos[p] * nx - sin[p] * ny
        poly[j, 3] = sin[p] * nx + cos[p] * ny


@njit(inline="always")
def ground_polygon(xs, ys, i, poly):
    """The ground under segment i into ``poly`` (4, 4), as :func:`block_polygon`: from the
    segment's left end down, along the bottom, up to its right end (counter-clockwise)."""
    base = min(ys[i], ys[i + 1]) - GROUND_DEPTH
    poly[0, 0] = xs[i]
    poly[0, 1] = ys[i]
    poly[1, 0] = xs[i]
    poly[1, 1] = base
    poly[2, 0] = xs[i + 1]
    poly[2, 1] = base
    poly[3, 0] = xs[i + 1]
    poly[3, 1] = ys[i + 1]
    for j in range(4):
        k = (j + 1) % 4
        ex = poly[k, 0] - poly[j, 0]
        ey = poly[k, 1] - poly[j, 1]
        length = math.sqrt(ex * ex + ey * ey)
        poly[j, 2] = ey / length
        poly[j, 3] = -ex / length


@njit(inline="always")
def above_segment(xs, ys, i, poly):
    """Whether the quadrilateral ``poly`` lies wholly above the line of terrain segment i, so
    that the separating-axis test of it against the ground under the segment
    (:func:`deepest_axis` of :func:`ground_polygon`) would find them apart: that test's own
    arithmetic for the segment's face, done alone (most blocks near the ground are above the
    segments their bounding boxes reach)."""
    ex = xs[i] - xs[i + 1]
    ey = ys[i] - ys[i + 1]
    length = math.sqrt(ex * ex + ey * ey)
    ax = ey / length
    ay = -ex / length
    top = ax * xs[i + 1] + ay * ys[i + 1]
    low = 1e300
    for q in range(4):
        low = min(low, ax * poly[q, 0] + ay * poly[q, 1])
    return top - low <= 0.0


# deepest_axis and manifold are called, not inlined: add_contacts, twice in find_contacts,
# inlined them (and manifold its two clips and farthest edges) at each site, seconds of
# compiling for what LLVM inlines or calls at no measurable cost.
@uncounted
def deepest_axis(one, two):
    """The separating-axis test of two convex quadrilaterals: (overlap, nx, ny) with the
    normal of least penetration, from ``one`` towards ``two`` (ties to ``one``'s faces);
    overlap <= 0 when they do not touch."""
    best = 1e300
    bx = by = 0.0
    for side in range(2):
        ref = one if side == 0 else two
        other = two if side == 0 else one
        for j in range(4):
            ax = ref[j, 2]
            ay = ref[j, 3]
            top = ax * ref[j, 0] + ay * ref[j, 1]
            low = 1e300
            for q in range(4):
                low = min(low, ax * other[q, 0] + ay * other[q, 1])
            depth = top - low
            if depth <= 0.0:
                return 0.0, 0.0, 0.0
            if depth < best:
                best = depth
                bx = ax if side == 0 else -ax
                by = ay if side == 0 else -ay
    return best, bx, by


@njit(inline="always")
def farthest_edge(poly, nx, ny):
    """The edge of ``poly`` farthest along (nx, ny): (first vertex, second vertex, the
    farthest vertex): of the two edges at the farthest vertex, the one whose normal is nearer
    to (nx, ny)."""
    far = 0
    top = -1e300
    for j in range(4):
        d = nx * poly[j, 0] + ny * poly[j, 1]
        if d > top:
            top = d
            far = j
    before = (far + 3) % 4
    if poly[before, 2] * nx + poly[before, 3] * ny < poly[far, 2] * nx + poly[far, 3] * ny:
        return far, (far + 1) % 4, far
    return before, far, far


@njit(inline="always")
def clip(clipped, n_in, nx, ny, offset):
    """Keep the part of segment ``clipped`` (rows 0, 1: x, y, vertex) on the side
    n . p <= offset; returns how many points remain (in rows 0, 1)."""
    d0 = nx * clipped[0, 0] + ny * clipped[0, 1] - offset
    d1 = nx * clipped[1, 0] + ny * clipped[1, 1] - offset
    if n_in < 2:
        return 0
    if d0 <= 0.0 and d1 <= 0.0:
        return 2
    if d0 > 0.0 and d1 > 0.0:
        return 0
    u = d0 / (d0 - d1)
    x = clipped[0, 0] + u * (clipped[1, 0] - clipped[0, 0])
    y = clipped[0, 1] + u * (clipped[1, 1] - clipped[0, 1])
    # The new point keeps the feature of the one it replaces.
    if d0 > 0.0:
        clipped[0, 0] = x
        clipped[0, 1] = y
    else:
        clipped[1, 0] = x
        clipped[1, 1] = y
    return 2


@uncounted
def manifold(one, two, nx, ny, clipped):
    """The contact points of two overlapping quadrilaterals (normal (nx, ny) from ``one``
    towards ``two``), as dyn4j's clipping manifold: the edge of either most perpendicular to
    the normal is the reference, the other's edge facing it is clipped to the reference's
    sides, and the clipped points behind the reference face are the contacts. Returns
    (points, flipped, reference edge, incident edge, the reference face's normal from ``one``
    towards ``two``); ``clipped`` rows: x, y, vertex, depth."""
    r1, r2, rm = farthest_edge(one, nx, ny)
    i1, i2, im = farthest_edge(two, -nx, -ny)
    e1x = one[r2, 0] - one[r1, 0]
    e1y = one[r2, 1] - one[r1, 1]
    e2x = two[i2, 0] - two[i1, 0]
    e2y = two[i2, 1] - two[i1, 1]
    flipped = abs(e1x * nx + e1y * ny) > abs(e2x * nx + e2y * ny)
    ref = two if flipped else one
    inc = one if flipped else two
    if flipped:
        r1, r2, rm, i1, i2 = i1, i2, im, r1, r2
    ex = ref[r2, 0] - ref[r1, 0]
    ey = ref[r2, 1] - ref[r1, 1]
    length = math.sqrt(ex * ex + ey * ey)
    ex /= length
    ey /= length
    clipped[0, 0] = inc[i1, 0]
    clipped[0, 1] = inc[i1, 1]
    clipped[0, 2] = i1
    clipped[1, 0] = inc[i2, 0]
    clipped[1, 1] = inc[i2, 1]
    clipped[1, 2] = i2
    kept = clip(clipped, 2, -ex, -ey, -(ex * ref[r1, 0] + ey * ref[r1, 1]))
    kept = clip(clipped, kept, ex, ey, ex * ref[r2, 0] + ey * ref[r2, 1])
    # Into the reference polygon: a point behind its face has depth >= 0.
    fx = -ey
    fy = ex
    tx = fx if flipped else -fx
    ty = fy if flipped else -fy
    if kept < 2:
        return 0, flipped, r1, i1, tx, ty
    front = fx * ref[rm, 0] + fy * ref[rm, 1]
    points = 0
    for q in range(2):
        depth = fx * clipped[q, 0] + fy * clipped[q, 1] - front
        if depth >= 0.0:
            for j in range(3):
                clipped[points, j] = clipped[q, j]
            clipped[points, 3] = depth
            points += 1
    return points, flipped, r1, i1, tx, ty


@njit(inline="always")
def add_contacts(robot, state, pos, a, b, partner, polygons, mu) -> int:
    """The contacts of body a (polygon ``two`` of ``polygons`` = (one, two)) with body b
    (polygon ``one``; b < 0: the ground, ``partner`` its segment, else ``partner`` = b) into the
    contact table, warm-started from last step's point of the same feature; returns how
    many."""
    one, two = polygons
    overlap, nx, ny = deepest_axis(one, two)
    if overlap <= 0.0:
        return 0
    clipped = state.clipped
    points, flipped, ref, inc, snx, sny = manifold(one, two, nx, ny, clipped)
    if points == 0:
        return 0
    c = state.contacts
    old = state.previous
    n = state.counts[0]
    if n + points > c.shape[0]:
        return 0  # the table is full (robot.contact_capacity): this pair waits a step
    cos = state.cos
    sin = state.sin
    for q in range(points):
        k = n + q
        px = clipped[q, 0]
        py = clipped[q, 1]
        feature = ((((partner * 2 + (1 if flipped else 0)) * 4 + ref) * 4 + inc) * 4
                   + int(clipped[q, 2]))
        c[k, C_A] = a
        c[k, C_B] = b
        c[k, C_FEATURE] = feature
        c[k, C_PX] = px
        c[k, C_PY] = py
        c[k, C_DEPTH] = clipped[q, 3]
        c[k, C_NX] = snx
        c[k, C_NY] = sny
        dx = px - pos[a, 0]
        dy = py - pos[a, 1]
        c[k, C_LAX] = cos[a] * dx + sin[a] * dy
        c[k, C_LAY] = -sin[a] * dx + cos[a] * dy
        if b >= 0:
            dx = px - pos[b, 0]
            dy = py - pos[b, 1]
            c[k, C_LBX] = cos[b] * dx + sin[b] * dy
            c[k, C_LBY] = -sin[b] * dx + cos[b] * dy
        else:
            c[k, C_LBX] = px
            c[k, C_LBY] = py
        c[k, C_COUNT] = points if q == 0 else 0.0
        c[k, C_LIVE] = 1.0
        c[k, C_MU] = mu
        c[k, C_JN] = 0.0
        c[k, C_JT] = 0.0
        for i in range(state.counts[1]):
            if (old[i, C_FEATURE] == feature and old[i, C_A] == a and old[i, C_B] == b
                    and old[i, C_LIVE] != 0.0):
                c[k, C_JN] = old[i, C_JN]
                c[k, C_JT] = old[i, C_JT]
                break
    state.counts[0] = n + points
    return points


@uncounted
def find_contacts(robot, ground, state, pos, params):
    """The contacts for the next step (dyn4j finds them after each step): each block against
    the ground under every terrain segment its bounding box reaches, and the blocks that share
    no joint against each other. ``state.contact`` says which blocks touch the ground."""
    c = state.contacts
    old = state.previous
    n_old = state.counts[0]
    for k in range(n_old):
        for j in range(N_CONTACT_COLUMNS):
            old[k, j] = c[k, j]
    state.counts[1] = n_old
    state.counts[0] = 0
    xs = ground.xs
    ys = ground.ys
    n = ground.n
    one = state.polygon[0]
    two = state.polygon[1]
    cos = state.cos
    sin = state.sin
    segment = state.segment
    top = ground_top(xs, ys, n, pos, robot.n_points, segment[robot.n_points])
    left = n
    for p in range(robot.n_points):
        state.contact[p] = False
        if pos[p, 1] - CLEAR_REACH > top:
            continue  # every segment's test below would find the block above it
        # The normals only for a block that reaches a segment's ground: most blocks are above.
        normals = False
        block_vertices(p, pos, cos, sin, two)
        lo_x = hi_x = two[0, 0]
        lo_y = two[0, 1]
        for j in range(1, 4):
            lo_x = min(lo_x, two[j, 0])
            hi_x = max(hi_x, two[j, 0])
            lo_y = min(lo_y, two[j, 1])
        i = segment_near(xs, n, lo_x, segment[p])
        segment[p] = i
        left = min(left, i)
        while i < n - 1 and xs[i] < hi_x:
            if lo_y < max(ys[i], ys[i + 1]) and not above_segment(xs, ys, i, two):
                if not normals:
                    block_normals(p, cos, sin, two)
                    normals = True
                ground_polygon(xs, ys, i, one)
                if add_contacts(robot, state, pos, p, -1, i, (one, two),
                                params.friction) > 0:
                    state.contact[p] = True
            i += 1
    if left < n:  # else every block was clear of the ground: the last step's guess stands
        segment[robot.n_points] = left
    for q in range(robot.n_pairs):
        a = robot.pair_ends[q, 0]
        b = robot.pair_ends[q, 1]
        dx = pos[b, 0] - pos[a, 0]
        dy = pos[b, 1] - pos[a, 1]
        if dx * dx + dy * dy >= 4.0 * BLOCK_REACH * BLOCK_REACH:
            continue
        block_polygon(a, pos, cos, sin, one)
        block_polygon(b, pos, cos, sin, two)
        add_contacts(robot, state, pos, b, a, a, (one, two), params.block_friction)


@njit(inline="always")
def velocities(robot, vel, params):
    """Gravity, then damping (dyn4j's: the velocity times 1 - dt * drag)."""
    dt = params.dt
    keep = min(max(1.0 - dt * params.drag, 0.0), 1.0)
    for p in range(robot.n_points):
        vel[p, 1] -= params.gravity * dt
        vel[p, 0] *= keep
        vel[p, 1] *= keep
        vel[p, 2] *= keep


@njit
def moved(p0, p1, p2, v0, v1, v2, dt):
    """A body's position and velocity after it moves for ``dt`` with velocity (v0, v1, v2), at
    most MAX_TRANSLATION and MAX_ROTATION a step (a faster velocity is cut to that): the new
    position, then the velocity."""
    tx = v0 * dt
    ty = v1 * dt
    square = tx * tx + ty * ty
    ratio = MAX_TRANSLATION / math.sqrt(square)
    fast = square > MAX_TRANSLATION * MAX_TRANSLATION
    v0 = v0 * ratio if fast else v0
    v1 = v1 * ratio if fast else v1
    rotation = v2 * dt
    spin = rotation * rotation > MAX_ROTATION * MAX_ROTATION
    v2 = v2 * (MAX_ROTATION / abs(rotation)) if spin else v2
    return p0 + v0 * dt, p1 + v1 * dt, p2 + v2 * dt, v0, v1, v2


@njit(inline="always")
def positions(robot, state, pos, vel, params):
    """Move the bodies with their velocities (:func:`moved`) and turn them."""
    for p in range(robot.n_points):
        pos[p, 0], pos[p, 1], pos[p, 2], vel[p, 0], vel[p, 1], vel[p, 2] = moved(
            pos[p, 0], pos[p, 1], pos[p, 2], vel[p, 0], vel[p, 1], vel[p, 2], params.dt)
        state.cos[p], state.sin[p] = sincos(pos[p, 2])


class Alone(NamedTuple):
    """One robot as a solver of :func:`somite.sim.step.step`: its arrays, as every function
    here takes them (``pos``, ``vel``: its bodies' state (P, 3), ``state.body_pos`` and
    ``state.body_vel`` on the CPU)."""

    robot: Robot
    ground: Ground
    state: BodyState
    pos: np.ndarray
    vel: np.ndarray


@implements(order.begin, Alone, on_device=True)
@njit(inline="always")
def _begin(solver, params):
    velocities(solver.robot, solver.vel, params)
    start_contacts(solver.robot, solver.state, solver.pos, solver.vel, params)


@implements(order.start_joints, Alone, on_device=True)
@njit(inline="always")
def _start_joints(solver, params):
    start_springs(solver.robot, solver.state, solver.pos, solver.vel, params)
    start_ropes(solver.robot, solver.state, solver.pos, solver.vel)
    start_welds(solver.robot, solver.state, solver.vel)


@implements(order.solve_joints, Alone, on_device=True)
@njit(inline="always")
def _solve_joints(solver, params):
    solve_springs(solver.robot, solver.state, solver.vel)
    solve_ropes(solver.robot, solver.state, solver.vel)
    solve_welds(solver.robot, solver.state, solver.vel)


@implements(order.solve_contacts, Alone, on_device=True)
@njit(inline="always")
def _solve_contacts(solver, params):
    solve_contacts(solver.robot, solver.state, solver.vel)


@implements(order.move, Alone, on_device=True)
@njit(inline="always")
def _move(solver, params):
    positions(solver.robot, solver.state, solver.pos, solver.vel, params)


@implements(order.fix_positions, Alone, on_device=True)
@njit(inline="always")
def _fix_positions(solver, params):
    contacts_held = fix_contacts(solver.robot, solver.state, solver.pos, solver.state.cos,
                                 solver.state.sin)
    ropes_held = fix_ropes(solver.robot, solver.pos)
    welds_held = fix_welds(solver.robot, solver.pos, solver.state.cos, solver.state.sin)
    return contacts_held and ropes_held and welds_held


@implements(order.end, Alone, on_device=True)
@njit(inline="always")
def _end(solver, params):
    find_contacts(solver.robot, solver.ground, solver.state, solver.pos, params)


@uncounted
def advance(robot, ground, state, params, substeps):
    """One control step of physics: ``substeps`` steps (:func:`somite.sim.step.step`) of the
    robot's :class:`~somite.sim.state.BodyState` ``state`` under its rest lengths
    (``state.rest``), from any state (the bodies' rotations are taken afresh).

    Compiled without Numba's reference counting (``_jit.uncounted``: nothing here allocates), as
    every field read from the per-robot tuples would otherwise cost an atomic increment and
    decrement on each step.
    """
    turn(robot.n_points, state.body_pos, state.cos, state.sin)
    alone = Alone(robot, ground, state, state.body_pos, state.body_vel)
    for _ in range(substeps):
        physics_step(alone, params)


@njit(inline="always")
def voxel_corners(corners, v):
    """Body indices of voxel ``v``'s corners: SW, SE, NE, NW (counter-clockwise)."""
    return corners[v, 0], corners[v, 1], corners[v, 2], corners[v, 3]


@uncounted
def corner_state(robot, pos, vel, cos, sin, corner_pos, corner_vel):
    """Each block's outer corner (the voxel's corner it carries) and the block's velocity:
    what the sensors, the recording and the diagnostics see (the original's voxel velocity is
    the mean of its blocks' velocities). ``cos``, ``sin``: the bodies' rotations, as the
    steps leave them in :class:`BodyState`."""
    offset = robot.corner_offset
    for p in range(robot.n_points):
        rx, ry = turned(p, offset[p, 0], offset[p, 1], cos, sin)
        corner_pos[p, 0] = pos[p, 0] + rx
        corner_pos[p, 1] = pos[p, 1] + ry
        corner_vel[p, 0] = vel[p, 0]
        corner_vel[p, 1] = vel[p, 1]


@uncounted
def lowest_gap(robot, ground, pos, cos, sin, segment) -> float:
    """How high [m] the robot's lowest block corner is above the ground under it (``cos``,
    ``sin`` as for :func:`corner_state`; ``segment``: each block's segment index as
    :func:`find_contacts` leaves it, where the search for its corners' starts: the index it
    finds does not depend on where it starts, only the walk's length does)."""
    gap = math.inf
    top = ground_top(ground.xs, ground.ys, ground.n, pos, robot.n_points,
                     segment[robot.n_points])
    for p in range(robot.n_points):
        if pos[p, 1] - CLEAR_REACH - top > gap:
            continue  # each corner's gap is larger: the minimum stays what it is
        for j in range(4):
            lx = HALF_BLOCK if j == 1 or j == 2 else -HALF_BLOCK
            ly = HALF_BLOCK if j >= 2 else -HALF_BLOCK
            x, y = world_point(p, lx, ly, pos, cos, sin)
            gap = min(gap, y - ground_height(ground.xs, ground.ys, ground.n, x, segment[p]))
    return gap
