"""Physics of one robot: rigid corner bodies joined by damped springs, rope limits, gravity,
drag and terrain contact.

Every function here works on one robot's arrays and is called from the episode loop of
:mod:`somite.tasks.episode`; the batch kernel runs that loop for each robot on its own thread.
A robot's state is one rigid body per lattice point (the voxels' corner blocks that meet there,
welded, as in the original): ``pos`` (P, 3) holds each body's centre of mass and angle, ``vel``
(P, 3) its velocity and angular velocity. The integrator is semi-implicit (symplectic) Euler:
velocities first from the forces and torques, then positions from the new velocities, then the
hard constraints (rope limits, each voxel's orientation, contact of the blocks with the
terrain) act on positions and velocities. The model and its fitted parameters: README, "The
simulator"; BENCHMARKS.md, "Fidelity".
"""

from __future__ import annotations

import math

from .._jit import njit
from .config import BLOCK_SIDE, VOXEL_SIDE

CONTACT_TOLERANCE = 0.01
"""An outline vertex within this height [m] of the ground counts as touching it."""
RESTITUTION_SPEED = 1.0
"""[m/s] Slower impacts do not bounce (the original's solver: dyn4j's velocity threshold)."""
HALF_BLOCK = BLOCK_SIDE / 2
BLOCK_REACH = HALF_BLOCK * math.sqrt(2.0)
"""Farthest a point of a block is from its centre [m]."""


@njit(inline="always")
def spring_length(kind: int, scale: float) -> float:
    """Length [m] of a spring of group ``kind`` in a voxel whose side is ``scale`` times the
    rest side (original-system.md section 1.2): the side springs span the gap between two
    blocks, the cross springs join one block's outer corner to the next one's inner corner,
    the central springs join the centres of opposite blocks."""
    gap = VOXEL_SIDE * scale - 2.0 * BLOCK_SIDE
    if kind == 0:
        return gap
    if kind == 1:
        return math.sqrt(BLOCK_SIDE * BLOCK_SIDE + gap * gap)
    return (VOXEL_SIDE * scale - BLOCK_SIDE) * math.sqrt(2.0)


@njit(_nrt=False)
def set_rest_lengths(n_springs, kind, owner, actuation, contract, expand, rest):
    """``rest``: the rest length of each spring for its voxel's ``actuation`` (V,): from its
    group's rest length towards its length in a voxel of side ``contract`` x 3 m at +1, of
    ``expand`` x 3 m at -1, linearly. Arrays, not the :class:`Robot` tuple: this function is
    not inlined, and passing the tuples costs 1-2% of the kernel's time."""
    for s in range(n_springs):
        a = min(1.0, max(-1.0, actuation[owner[s]]))
        k = kind[s]
        r0 = spring_length(k, 1.0)
        if a >= 0.0:
            rest[s] = r0 - (r0 - spring_length(k, contract)) * a
        else:
            rest[s] = r0 + (spring_length(k, expand) - r0) * (-a)


@njit(inline="always")
def turn(n_points, pos, cos, sin):
    """Each body's rotation for this substep."""
    for p in range(n_points):
        cos[p] = math.cos(pos[p, 2])
        sin[p] = math.sin(pos[p, 2])


@njit(inline="always")
def turned(p, ox, oy, cos, sin):
    """Offset (ox, oy) in body p's frame, turned into the world's."""
    return cos[p] * ox - sin[p] * oy, sin[p] * ox + cos[p] * oy


@njit(inline="always")
def integrate(robot, scratch, pos, vel, params):
    """One semi-implicit Euler step of springs, gravity and drag.

    A spring's stiffness and damping are ``params.stiffness`` and ``params.damping`` times its
    effective mass (``robot.spring_mass``), as the original sets a joint's from its frequency
    and damping ratio. ``scratch.force`` must hold zeros on entry and holds zeros on exit;
    ``scratch.cos`` and ``scratch.sin`` must hold the bodies' rotations on entry, and hold the
    new ones on exit. The springs go in three passes (gather, forces, scatter) so that the
    middle one has no branch and no indirect access, and compiles to SIMD code; ``scratch.rax``
    .. ``scratch.tb`` are (S,) work arrays, separate so that the compiler knows they do not
    overlap.
    """
    n_points = robot.n_points
    n_springs = robot.n_springs
    ends = robot.ends
    anchor = robot.anchor
    spring_mass = robot.spring_mass
    inv_mass = robot.inv_mass
    inv_inertia = robot.inv_inertia
    rest = scratch.rest
    force = scratch.force
    cos = scratch.cos
    sin = scratch.sin
    raxs = scratch.rax
    rays = scratch.ray
    rbxs = scratch.rbx
    rbys = scratch.rby
    dxs = scratch.dx
    dys = scratch.dy
    dvxs = scratch.dvx
    dvys = scratch.dvy
    fxs = scratch.fx
    fys = scratch.fy
    tas = scratch.ta
    tbs = scratch.tb
    dt = params.dt
    k = params.stiffness
    c = params.damping
    g = params.gravity
    drag = params.drag
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        rax, ray = turned(a, anchor[s, 0], anchor[s, 1], cos, sin)
        rbx, rby = turned(b, anchor[s, 2], anchor[s, 3], cos, sin)
        raxs[s] = rax
        rays[s] = ray
        rbxs[s] = rbx
        rbys[s] = rby
        dxs[s] = pos[b, 0] + rbx - pos[a, 0] - rax
        dys[s] = pos[b, 1] + rby - pos[a, 1] - ray
        dvxs[s] = vel[b, 0] - vel[b, 2] * rby - vel[a, 0] + vel[a, 2] * ray
        dvys[s] = vel[b, 1] + vel[b, 2] * rbx - vel[a, 1] - vel[a, 2] * rax
    for s in range(n_springs):
        dx = dxs[s]
        dy = dys[s]
        length = math.sqrt(dx * dx + dy * dy)
        inv = 1.0 / length
        closing = (dvxs[s] * dx + dvys[s] * dy) * inv
        f = spring_mass[s] * (k * (length - rest[s]) + c * closing) * inv
        fx = f * dx
        fy = f * dy
        fxs[s] = fx
        fys[s] = fy
        tas[s] = raxs[s] * fy - rays[s] * fx
        tbs[s] = rbxs[s] * fy - rbys[s] * fx
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        force[a, 0] += fxs[s]
        force[a, 1] += fys[s]
        force[a, 2] += tas[s]
        force[b, 0] -= fxs[s]
        force[b, 1] -= fys[s]
        force[b, 2] -= tbs[s]
    for p in range(n_points):
        step = inv_mass[p] * dt
        vel[p, 0] += force[p, 0] * step - drag * vel[p, 0] * dt
        vel[p, 1] += force[p, 1] * step - drag * vel[p, 1] * dt - g * dt
        vel[p, 2] += force[p, 2] * inv_inertia[p] * dt - drag * vel[p, 2] * dt
        pos[p, 0] += vel[p, 0] * dt
        pos[p, 1] += vel[p, 1] * dt
        pos[p, 2] += vel[p, 2] * dt
        cos[p] = math.cos(pos[p, 2])
        sin[p] = math.sin(pos[p, 2])
        force[p, 0] = 0.0
        force[p, 1] = 0.0
        force[p, 2] = 0.0


@njit(inline="always")
def _shift(p, rx, ry, nx, ny, amount, inv_mass, inv_inertia, state):
    """Apply ``amount`` along (nx, ny) at offset (rx, ry) of body p to ``state`` (a position
    correction or an impulse: the same arithmetic)."""
    state[p, 0] += nx * amount * inv_mass[p]
    state[p, 1] += ny * amount * inv_mass[p]
    state[p, 2] += (rx * ny - ry * nx) * amount * inv_inertia[p]


@njit(_nrt=False)
def keep_apart(a, b, rax, ray, rbx, rby, limit, inv_mass, inv_inertia, pos, vel, cos, sin):
    """Push the anchors (offsets ``ra``, ``rb`` in the world frame) of bodies a and b apart to
    distance ``limit`` and stop their closing, with the bodies' masses and inertias."""
    dx = pos[b, 0] + rbx - pos[a, 0] - rax
    dy = pos[b, 1] + rby - pos[a, 1] - ray
    length = math.sqrt(dx * dx + dy * dy)
    if length < 1e-9:
        dx = 0.0
        dy = 1.0
        length = 1.0
    nx = dx / length
    ny = dy / length
    rna = rax * ny - ray * nx
    rnb = rbx * ny - rby * nx
    w = (inv_mass[a] + inv_mass[b] + rna * rna * inv_inertia[a] + rnb * rnb * inv_inertia[b])
    push = (limit - length) / w
    _shift(a, rax, ray, nx, ny, -push, inv_mass, inv_inertia, pos)
    _shift(b, rbx, rby, nx, ny, push, inv_mass, inv_inertia, pos)
    dvx = vel[b, 0] - vel[b, 2] * rby - vel[a, 0] + vel[a, 2] * ray
    dvy = vel[b, 1] + vel[b, 2] * rbx - vel[a, 1] - vel[a, 2] * rax
    closing = dvx * nx + dvy * ny
    if closing < 0.0:
        _shift(a, rax, ray, nx, ny, closing / w, inv_mass, inv_inertia, vel)
        _shift(b, rbx, rby, nx, ny, -closing / w, inv_mass, inv_inertia, vel)
    for p in (a, b):
        cos[p] = math.cos(pos[p, 2])
        sin[p] = math.sin(pos[p, 2])


@njit(inline="always")
def keep_ropes(robot, scratch, pos, vel):
    """Hard limit: the centres of a voxel's adjacent blocks stay at least one block side apart,
    so the blocks never overlap and no controller can collapse a voxel (the original's rope
    joints; inversion is :func:`keep_orientation`'s)."""
    ends = robot.rope_ends
    anchor = robot.rope_anchor
    cos = scratch.cos
    sin = scratch.sin
    limit2 = BLOCK_SIDE * BLOCK_SIDE
    for r in range(robot.n_ropes):
        a = ends[r, 0]
        b = ends[r, 1]
        rax, ray = turned(a, anchor[r, 0], anchor[r, 1], cos, sin)
        rbx, rby = turned(b, anchor[r, 2], anchor[r, 3], cos, sin)
        dx = pos[b, 0] + rbx - pos[a, 0] - rax
        dy = pos[b, 1] + rby - pos[a, 1] - ray
        if dx * dx + dy * dy < limit2:
            keep_apart(a, b, rax, ray, rbx, rby, BLOCK_SIDE, robot.inv_mass, robot.inv_inertia,
                       pos, vel, cos, sin)


@njit(inline="always")
def highest_ground(xs, ys, n, first, hi_x) -> float:
    """The highest terrain point from segment ``first`` to x = hi_x."""
    i = first
    top = max(ys[i], ys[i + 1])
    while i + 1 < n - 1 and xs[i + 1] < hi_x:
        i += 1
        top = max(top, ys[i + 1])
    return top


@njit(inline="always")
def segment_near(xs, n, x, guess) -> int:
    """Index of the segment under x, walking from ``guess`` (a point moves little per step)."""
    i = min(max(guess, 0), n - 2)
    while i > 0 and x < xs[i]:
        i -= 1
    while i < n - 2 and x >= xs[i + 1]:
        i += 1
    return i


@njit(_nrt=False)
def ground_height(xs, ys, n, x, guess) -> float:
    """Height [m] of the terrain at x (``guess``: a segment index near x)."""
    i = segment_near(xs, n, x, guess)
    t = (x - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + t * (ys[i + 1] - ys[i])


@njit(inline="always")
def world_point(p, ox, oy, pos, cos, sin):
    """World position of offset (ox, oy) of body p."""
    return (pos[p, 0] + cos[p] * ox - sin[p] * oy, pos[p, 1] + sin[p] * ox + cos[p] * oy)


@njit(_nrt=False)
def touch(p, x, y, nx, ny, depth, mu, restitution, inv_mass, inv_inertia, pos, vel, dpos, dvel,
          hits):
    """Body p's point (x, y) is ``depth`` inside the ground, whose surface normal there is
    (nx, ny): add to ``dpos``, ``dvel`` (P, 3) what pushes the body out along the normal and
    what the ground's impulse does to an approaching point, all through the body's mass and
    inertia, as if this were its only contact; count them in ``hits`` (P, 2).

    The impulse stops the point's approach (bouncing back ``restitution`` of an approach
    faster than RESTITUTION_SPEED) and, when Coulomb friction can (within ``mu`` times the
    normal impulse), its sliding; otherwise it slides, with friction mu times the normal
    impulse, the way the impulse that would have stopped it points. The normal and the
    friction impulse are solved together: each turns the body, which moves the point along the
    other's direction too. :func:`settle` then applies each body's mean. Contacts computed
    from one state and averaged do not depend on the order in which they are found, so a robot
    and its mirror image move as mirror images.
    """
    rx = x - pos[p, 0]
    ry = y - pos[p, 1]
    tx = ny
    ty = -nx
    rn = rx * ny - ry * nx
    rt = rx * ty - ry * tx
    # How an impulse along the normal / tangent changes the point's velocity along each.
    k_nn = inv_mass[p] + rn * rn * inv_inertia[p]
    k_tt = inv_mass[p] + rt * rt * inv_inertia[p]
    k_nt = rn * rt * inv_inertia[p]
    _shift(p, rx, ry, nx, ny, depth / k_nn, inv_mass, inv_inertia, dpos)
    hits[p, 0] += 1.0
    vx = vel[p, 0] - vel[p, 2] * ry
    vy = vel[p, 1] + vel[p, 2] * rx
    vn = vx * nx + vy * ny
    if vn >= 0.0:
        return
    vt = vx * tx + vy * ty
    bounce = restitution if vn < -RESTITUTION_SPEED else 0.0
    want_n = -(1.0 + bounce) * vn
    det = k_nn * k_tt - k_nt * k_nt
    jn = (k_tt * want_n + k_nt * vt) / det  # the point sticks
    jt = (-k_nn * vt - k_nt * want_n) / det
    if jn < 0.0 or abs(jt) > mu * jn:
        # It slides: friction at its Coulomb limit, the way the impulse that would have
        # stopped it pushes. (The sliding before the impulse can point the other way, or be
        # zero.) Then k_nn + side * mu * k_nt > 0: were it not, the point would have stuck.
        side = 1.0 if jt > 0.0 else -1.0
        jn = want_n / (k_nn + side * mu * k_nt)
        jt = side * mu * jn
    _shift(p, rx, ry, nx, ny, jn, inv_mass, inv_inertia, dvel)
    _shift(p, rx, ry, tx, ty, jt, inv_mass, inv_inertia, dvel)
    hits[p, 1] += 1.0


@njit(inline="always")
def settle(n_points, dpos, dvel, hits, pos, vel, cos, sin):
    """Apply to each body the mean of its contacts' corrections (:func:`touch`): of the push
    over the contacts found, of the impulse over the approaching ones; update the body's
    rotation, and clear them."""
    for p in range(n_points):
        if hits[p, 0] > 0.0:
            share = 1.0 / hits[p, 0]
            for j in range(3):
                pos[p, j] += dpos[p, j] * share
                dpos[p, j] = 0.0
            if hits[p, 1] > 0.0:
                share = 1.0 / hits[p, 1]
                for j in range(3):
                    vel[p, j] += dvel[p, j] * share
                    dvel[p, j] = 0.0
            hits[p, 0] = hits[p, 1] = 0.0
            cos[p] = math.cos(pos[p, 2])
            sin[p] = math.sin(pos[p, 2])


@njit(inline="always")
def tip_contact(robot, ground, scratch, pos, vel, first, hi_x, params):
    """Keep the outline vertices of the robot's blocks out of the ground.

    ``scratch.segment`` remembers each vertex's segment from the previous substep; ``first``
    is the segment under the robot's leftmost point and ``hi_x`` its right end [m]. A vertex
    below its segment, further horizontally from the segment's ends than it is deep, goes
    straight out along the segment's normal (the usual case); otherwise the two neighbours on
    each side are searched for the nearest ground point, so that steep walls and step risers
    push sideways, not up. Found now, applied by :func:`settle` (:func:`touch`).
    """
    xs = ground.xs
    ys = ground.ys
    nxs = ground.nx
    nys = ground.ny
    n = ground.n
    contact = scratch.contact
    segment = scratch.segment
    cos = scratch.cos
    sin = scratch.sin
    clear = highest_ground(xs, ys, n, first, hi_x) + CONTACT_TOLERANCE
    for f in range(robot.n_tips):
        p = robot.tip_body[f]
        x, y = world_point(p, robot.tip_offset[f, 0], robot.tip_offset[f, 1], pos, cos, sin)
        if y >= clear:
            continue
        i = segment_near(xs, n, x, segment[f])
        segment[f] = i
        t = (x - xs[i]) / (xs[i + 1] - xs[i])
        gap = y - (ys[i] + t * (ys[i + 1] - ys[i]))
        if gap < CONTACT_TOLERANCE:
            contact[p] = True
        if gap >= 0.0:
            continue
        nx = nxs[i]
        ny = nys[i]
        if min(x - xs[i], xs[i + 1] - x) >= -gap:
            depth = -((x - xs[i]) * nx + (y - ys[i]) * ny)
        else:
            best = 1e300
            cx = cy = 0.0
            for j in range(max(0, i - 2), min(n - 1, i + 3)):
                sx = xs[j + 1] - xs[j]
                sy = ys[j + 1] - ys[j]
                u = ((x - xs[j]) * sx + (y - ys[j]) * sy) / (sx * sx + sy * sy)
                u = min(1.0, max(0.0, u))
                qx = xs[j] + u * sx
                qy = ys[j] + u * sy
                d2 = (x - qx) * (x - qx) + (y - qy) * (y - qy)
                if d2 < best:
                    best = d2
                    cx = qx
                    cy = qy
            depth = math.sqrt(best)
            if depth < 1e-9:
                continue
            nx = (cx - x) / depth
            ny = (cy - y) / depth
        if depth > 0.0:
            touch(p, x, y, nx, ny, depth, params.friction, params.restitution, robot.inv_mass,
                  robot.inv_inertia, pos, vel, scratch.dpos, scratch.dvel, scratch.hits)


@njit(inline="always")
def vertex_contact(robot, ground, scratch, pos, vel, first, hi_x, lo_y, params):
    """Keep terrain vertices out of the robot's outline blocks; the block leaves through its
    edge nearest to the vertex (:func:`touch`: found now, applied by :func:`settle`).

    Together with :func:`tip_contact` (block corners against terrain segments) this makes the
    blocks solid: a robot rests on a crest with a block's face, not only with a corner.
    """
    xs = ground.xs
    ys = ground.ys
    n = ground.n
    cos = scratch.cos
    sin = scratch.sin
    for i in range(first + 1, n - 1):
        tx = xs[i]
        if tx > hi_x:
            break
        ty = ys[i]
        if ty <= lo_y:
            continue  # below every outline vertex: it cannot be inside a block
        for q in range(robot.n_blocks):
            p = robot.block_body[q]
            bx, by = world_point(p, robot.block_offset[q, 0], robot.block_offset[q, 1], pos,
                                 cos, sin)
            if abs(tx - bx) >= BLOCK_REACH or abs(ty - by) >= BLOCK_REACH:
                continue
            lx = cos[p] * (tx - bx) + sin[p] * (ty - by)
            ly = -sin[p] * (tx - bx) + cos[p] * (ty - by)
            if abs(lx) >= HALF_BLOCK or abs(ly) >= HALF_BLOCK:
                continue
            # The block moves away from the vertex, through the nearest edge.
            depth = HALF_BLOCK - lx
            ex = -1.0
            ey = 0.0
            if HALF_BLOCK + lx < depth:
                depth = HALF_BLOCK + lx
                ex = 1.0
                ey = 0.0
            if HALF_BLOCK - ly < depth:
                depth = HALF_BLOCK - ly
                ex = 0.0
                ey = -1.0
            if HALF_BLOCK + ly < depth:
                depth = HALF_BLOCK + ly
                ex = 0.0
                ey = 1.0
            scratch.contact[p] = True
            touch(p, tx, ty, cos[p] * ex - sin[p] * ey, sin[p] * ex + cos[p] * ey, depth,
                  params.friction, params.restitution, robot.inv_mass, robot.inv_inertia, pos,
                  vel, scratch.dpos, scratch.dvel, scratch.hits)


@njit(inline="always")
def tip_extent(robot, pos, cos, sin):
    """Leftmost x, rightmost x and lowest y of the robot's outline vertices."""
    lo_x = hi_x = lo_y = 0.0
    for f in range(robot.n_tips):
        x, y = world_point(robot.tip_body[f], robot.tip_offset[f, 0], robot.tip_offset[f, 1],
                           pos, cos, sin)
        if f == 0:
            lo_x = hi_x = x
            lo_y = y
        else:
            lo_x = min(lo_x, x)
            hi_x = max(hi_x, x)
            lo_y = min(lo_y, y)
    return lo_x, hi_x, lo_y


@njit(inline="always")
def voxel_corners(corners, v):
    """Point indices of voxel ``v``'s corners: SW, SE, NE, NW (counter-clockwise)."""
    return corners[v, 0], corners[v, 1], corners[v, 2], corners[v, 3]


@njit(inline="always")
def keep_orientation(robot, scratch, pos, vel):
    """No voxel turns inside out: the signed area of each voxel's outline (its corner bodies'
    lattice points) stays at least ``min_area``.

    Rope limits cannot do it (a mirrored voxel has the same distances). The check is inlined;
    the rare correction (:func:`restore_area`) is not, which keeps the substep's code small.
    """
    corners = robot.corners
    offset = robot.corner_offset
    cos = scratch.cos
    sin = scratch.sin
    for v in range(robot.n_voxels):
        sw, se, ne, nw = voxel_corners(corners, v)
        swx, swy = world_point(sw, offset[sw, 0], offset[sw, 1], pos, cos, sin)
        sex, sey = world_point(se, offset[se, 0], offset[se, 1], pos, cos, sin)
        nex, ney = world_point(ne, offset[ne, 0], offset[ne, 1], pos, cos, sin)
        nwx, nwy = world_point(nw, offset[nw, 0], offset[nw, 1], pos, cos, sin)
        # Twice the signed area: the cross product of the diagonals.
        d1x = nex - swx
        d1y = ney - swy
        d2x = nwx - sex
        d2y = nwy - sey
        if 0.5 * (d1x * d2y - d1y * d2x) < robot.min_area:
            restore_area(sw, se, ne, nw, d1x, d1y, d2x, d2y, robot.min_area, robot.inv_mass,
                         pos, vel, nex - pos[ne, 0], ney - pos[ne, 1], nwx - pos[nw, 0],
                         nwy - pos[nw, 1], swx - pos[sw, 0], swy - pos[sw, 1],
                         sex - pos[se, 0], sey - pos[se, 1])


@njit(inline="always")
def _point_velocity(p, rx, ry, vel):
    return vel[p, 0] - vel[p, 2] * ry, vel[p, 1] + vel[p, 2] * rx


@njit(_nrt=False)
def restore_area(sw, se, ne, nw, d1x, d1y, d2x, d2y, min_area, inv_mass, pos, vel, r_ne_x,
                 r_ne_y, r_nw_x, r_nw_y, r_sw_x, r_sw_y, r_se_x, r_se_y):
    """Move the corner bodies of a voxel smaller than ``min_area`` (diagonals d1 = NE - SW,
    d2 = NW - SE; r_*: each corner's offset from its body's centre, world frame) along its
    area's gradient, weighted by inverse mass, to restore ``min_area``, and remove the
    shrinking rate of its corners (from the bodies' motion and spin) along it. Translations
    only: moving a body moves its lattice point by as much."""
    area = 0.5 * (d1x * d2y - d1y * d2x)
    # dA/dp for each corner: half the perpendicular of the other diagonal.
    g_sw_x, g_sw_y = -0.5 * d2y, 0.5 * d2x
    g_ne_x, g_ne_y = 0.5 * d2y, -0.5 * d2x
    g_se_x, g_se_y = 0.5 * d1y, -0.5 * d1x
    g_nw_x, g_nw_y = -0.5 * d1y, 0.5 * d1x
    w_sw = inv_mass[sw]
    w_se = inv_mass[se]
    w_ne = inv_mass[ne]
    w_nw = inv_mass[nw]
    norm = (w_sw * (g_sw_x * g_sw_x + g_sw_y * g_sw_y)
            + w_ne * (g_ne_x * g_ne_x + g_ne_y * g_ne_y)
            + w_se * (g_se_x * g_se_x + g_se_y * g_se_y)
            + w_nw * (g_nw_x * g_nw_x + g_nw_y * g_nw_y))
    if norm < 1e-12:
        return
    step = (min_area - area) / norm
    v_sw_x, v_sw_y = _point_velocity(sw, r_sw_x, r_sw_y, vel)
    v_se_x, v_se_y = _point_velocity(se, r_se_x, r_se_y, vel)
    v_ne_x, v_ne_y = _point_velocity(ne, r_ne_x, r_ne_y, vel)
    v_nw_x, v_nw_y = _point_velocity(nw, r_nw_x, r_nw_y, vel)
    rate = (g_sw_x * v_sw_x + g_sw_y * v_sw_y + g_ne_x * v_ne_x + g_ne_y * v_ne_y
            + g_se_x * v_se_x + g_se_y * v_se_y + g_nw_x * v_nw_x + g_nw_y * v_nw_y)
    stop = max(0.0, -rate) / norm
    for p, gx, gy, w in ((sw, g_sw_x, g_sw_y, w_sw), (se, g_se_x, g_se_y, w_se),
                         (ne, g_ne_x, g_ne_y, w_ne), (nw, g_nw_x, g_nw_y, w_nw)):
        pos[p, 0] += step * w * gx
        pos[p, 1] += step * w * gy
        vel[p, 0] += stop * w * gx
        vel[p, 1] += stop * w * gy


@njit(inline="always")
def substep(robot, ground, scratch, pos, vel, params):
    """Advance one robot by one physics substep: springs, gravity and drag; the rope limits
    and each voxel's orientation; contact of the blocks with the terrain. ``scratch.cos`` and
    ``scratch.sin`` must hold the bodies' rotations (:func:`turn`); every step that turns a
    body updates them."""
    integrate(robot, scratch, pos, vel, params)
    keep_ropes(robot, scratch, pos, vel)
    keep_orientation(robot, scratch, pos, vel)
    lo_x, hi_x, lo_y = tip_extent(robot, pos, scratch.cos, scratch.sin)
    segment = scratch.segment
    first = segment_near(ground.xs, ground.n, lo_x, segment[robot.n_tips])
    segment[robot.n_tips] = first
    for p in range(robot.n_points):
        scratch.contact[p] = False
    tip_contact(robot, ground, scratch, pos, vel, first, hi_x, params)
    vertex_contact(robot, ground, scratch, pos, vel, first, hi_x, lo_y, params)
    settle(robot.n_points, scratch.dpos, scratch.dvel, scratch.hits, pos, vel, scratch.cos,
           scratch.sin)


@njit(_nrt=False)
def advance(robot, ground, scratch, pos, vel, params, substeps):
    """One control step of physics: ``substeps`` substeps under the rest lengths of
    ``scratch.rest``, from any state (the bodies' rotations are taken afresh).

    Compiled without Numba's reference counting (``_nrt=False``: nothing here allocates), as
    every field read from the per-robot tuples would otherwise cost an atomic increment and
    decrement on each substep.
    """
    turn(robot.n_points, pos, scratch.cos, scratch.sin)
    for _ in range(substeps):
        substep(robot, ground, scratch, pos, vel, params)


@njit(_nrt=False)
def corner_state(robot, pos, vel, cos, sin, corner_pos, corner_vel):
    """The lattice points (the voxels' corners, one per body) and their velocities: what the
    sensors, the recording and the diagnostics see. ``cos``, ``sin``: the bodies' rotations,
    as the substeps leave them in :class:`Scratch` (every step that turns a body updates
    them)."""
    offset = robot.corner_offset
    for p in range(robot.n_points):
        rx, ry = turned(p, offset[p, 0], offset[p, 1], cos, sin)
        corner_pos[p, 0] = pos[p, 0] + rx
        corner_pos[p, 1] = pos[p, 1] + ry
        corner_vel[p, 0] = vel[p, 0] - vel[p, 2] * ry
        corner_vel[p, 1] = vel[p, 1] + vel[p, 2] * rx


@njit(_nrt=False)
def lowest_gap(robot, ground, pos, cos, sin, guess) -> float:
    """How high [m] the robot's lowest outline vertex is above the ground under it
    (``cos``, ``sin`` as for :func:`corner_state`; ``guess``: a segment index near the
    robot)."""
    gap = math.inf
    for f in range(robot.n_tips):
        x, y = world_point(robot.tip_body[f], robot.tip_offset[f, 0], robot.tip_offset[f, 1],
                           pos, cos, sin)
        gap = min(gap, y - ground_height(ground.xs, ground.ys, ground.n, x, guess))
    return gap
