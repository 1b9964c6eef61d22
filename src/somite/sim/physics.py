"""Physics of one robot: damped springs, gravity, drag, hard limits and terrain contact.

Every function here works on one robot's arrays (points ``pos``, ``vel`` of shape (P, 2)) and
is called from the episode loop of :mod:`somite.tasks.episode`; the batch kernel runs that loop
for each robot on its own thread. The integrator is semi-implicit (symplectic) Euler: velocities
first from the forces, then positions from the new velocities, then the hard constraints
(length limits, each voxel's orientation, contact of the outline with the terrain) act on
positions and velocities. The contact model and its fitted parameters: README, "The
simulator"; BENCHMARKS.md, "Fidelity".
"""

from __future__ import annotations

import math

from .._jit import njit

CONTACT_TOLERANCE = 0.01
"""A corner within this height [m] of the ground counts as touching it."""
MAX_SIDE_DEPTH = 1.5
"""Terrain vertices deeper than this [m] behind an outer side belong to another side."""


@njit
def rest_length_factor(actuation: float, contract: float, expand: float) -> float:
    """Rest-length scale of a voxel's springs: ``contract`` at a = +1, ``expand`` at a = -1."""
    a = min(1.0, max(-1.0, actuation))
    if a >= 0.0:
        return 1.0 - (1.0 - contract) * a
    return 1.0 + (expand - 1.0) * (-a)


@njit(_nrt=False)
def set_rest_lengths(n_voxels, n_springs, owners, rest0, actuation, contract, expand, factor,
                     rest):
    """``rest``: the rest length of each spring for the voxels' current ``actuation`` (V,), the
    mean over its owners; ``factor`` (V,) is work space. Arrays, not the :class:`Robot` and
    :class:`Scratch` tuples: this function is not inlined, and passing the tuples costs 1-2% of
    the kernel's time."""
    for v in range(n_voxels):
        factor[v] = rest_length_factor(actuation[v], contract, expand)
    for s in range(n_springs):
        f = factor[owners[s, 0]]
        if owners[s, 1] >= 0:
            f = 0.5 * (f + factor[owners[s, 1]])
        rest[s] = rest0[s] * f


@njit(inline="always")
def integrate(robot, scratch, pos, vel, params):
    """One semi-implicit Euler step of springs, gravity and drag.

    ``strength`` scales each spring's stiffness and damping: the number of voxels owning a side
    (1 or 2: parallel springs add up), ``diagonal_stiffness`` for a diagonal.
    ``scratch.force`` must hold zeros on entry and holds zeros on exit; ``scratch.dx`` ..
    ``scratch.fy`` are (S,) work arrays, separate so that the compiler knows they do not
    overlap.
    The springs go in three passes (gather, forces, scatter) so that the middle one has no
    branch and no indirect access, and compiles to SIMD code. It also counts the springs
    shorter than their ``min_length``; only when there are any (rarely) does the hard limit
    (:func:`enforce_min_lengths`) run, before the velocities change.
    """
    n_points = robot.n_points
    n_springs = robot.n_springs
    ends = robot.ends
    strength = robot.strength
    min_length = robot.min_length
    mass = robot.mass
    inv_mass = robot.inv_mass
    rest = scratch.rest
    force = scratch.force
    dxs = scratch.dx
    dys = scratch.dy
    dvx = scratch.dvx
    dvy = scratch.dvy
    fxs = scratch.fx
    fys = scratch.fy
    dt = params.dt
    k = params.stiffness
    c = params.damping
    g = params.gravity
    drag = params.drag
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        dxs[s] = pos[b, 0] - pos[a, 0]
        dys[s] = pos[b, 1] - pos[a, 1]
        dvx[s] = vel[b, 0] - vel[a, 0]
        dvy[s] = vel[b, 1] - vel[a, 1]
    n_short = 0
    for s in range(n_springs):
        length = math.sqrt(dxs[s] * dxs[s] + dys[s] * dys[s])
        n_short += length < min_length[s]
        inv = 1.0 / length
        closing = (dvx[s] * dxs[s] + dvy[s] * dys[s]) * inv
        f = strength[s] * (k * (length - rest[s]) + c * closing) * inv
        fxs[s] = f * dxs[s]
        fys[s] = f * dys[s]
    if n_short > 0:
        enforce_min_lengths(n_springs, ends, min_length, inv_mass, pos, vel)
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        force[a, 0] += fxs[s]
        force[a, 1] += fys[s]
        force[b, 0] -= fxs[s]
        force[b, 1] -= fys[s]
    for p in range(n_points):
        step = inv_mass[p] * dt
        vel[p, 0] += (force[p, 0] - drag * mass[p] * vel[p, 0]) * step
        vel[p, 1] += (force[p, 1] - drag * mass[p] * vel[p, 1]) * step - g * dt
        pos[p, 0] += vel[p, 0] * dt
        pos[p, 1] += vel[p, 1] * dt
        force[p, 0] = 0.0
        force[p, 1] = 0.0


@njit(_nrt=False)
def push_apart(a, b, length, limit, dx, dy, inv_mass, pos, vel):
    """Move points a, b apart (mass-weighted) to distance ``limit``; stop their closing."""
    if length < 1e-9:
        dx = 0.0
        dy = 1.0
        length = 1.0
    nx = dx / length
    ny = dy / length
    wa = inv_mass[a]
    wb = inv_mass[b]
    share = (limit - length) / (wa + wb)
    pos[a, 0] -= nx * share * wa
    pos[a, 1] -= ny * share * wa
    pos[b, 0] += nx * share * wb
    pos[b, 1] += ny * share * wb
    closing = (vel[b, 0] - vel[a, 0]) * nx + (vel[b, 1] - vel[a, 1]) * ny
    if closing < 0.0:
        impulse = closing / (wa + wb)
        vel[a, 0] += nx * impulse * wa
        vel[a, 1] += ny * impulse * wa
        vel[b, 0] -= nx * impulse * wb
        vel[b, 1] -= ny * impulse * wb


@njit(_nrt=False)
def enforce_min_lengths(n_springs, ends, min_length, inv_mass, pos, vel):
    """Hard limit: no side shorter than ``min_side_ratio`` of its rest length, no diagonal
    than ``min_diagonal_ratio``, so no controller can collapse a voxel (inversion is
    :func:`keep_orientation`'s). Also run after the last substep of each control step, so that
    what is sensed and recorded always obeys the limit. Arrays, not the :class:`Robot` tuple,
    as for :func:`set_rest_lengths`."""
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        dx = pos[b, 0] - pos[a, 0]
        dy = pos[b, 1] - pos[a, 1]
        limit = min_length[s]
        d2 = dx * dx + dy * dy
        if d2 < limit * limit:
            push_apart(a, b, math.sqrt(d2), limit, dx, dy, inv_mass, pos, vel)


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
def extent(n_points, pos):
    """Leftmost x, rightmost x and lowest y of a robot's corners."""
    lo_x = pos[0, 0]
    hi_x = pos[0, 0]
    lo_y = pos[0, 1]
    for p in range(1, n_points):
        lo_x = min(lo_x, pos[p, 0])
        hi_x = max(hi_x, pos[p, 0])
        lo_y = min(lo_y, pos[p, 1])
    return lo_x, hi_x, lo_y


@njit(inline="always")
def segment_near(xs, n, x, guess) -> int:
    """Index of the segment under x, walking from ``guess`` (a corner moves little per step)."""
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
def _bounce_off(p, vel, nx, ny, mu):
    """Remove point p's velocity into the surface of normal (nx, ny); Coulomb friction."""
    vn = vel[p, 0] * nx + vel[p, 1] * ny
    if vn < 0.0:
        vel[p, 0] -= vn * nx
        vel[p, 1] -= vn * ny
        tx = ny
        ty = -nx
        vt = vel[p, 0] * tx + vel[p, 1] * ty
        cut = min(abs(vt), -mu * vn)
        if vt < 0.0:
            cut = -cut
        vel[p, 0] -= cut * tx
        vel[p, 1] -= cut * ty


@njit(inline="always")
def ground_contact(robot, ground, scratch, pos, vel, first, hi_x, params):
    """Keep the robot's corners, rounded to discs of radius ``contact_radius``, out of the
    ground; no bounce, Coulomb friction.

    ``scratch.segment`` remembers each corner's segment from the previous substep; ``first``
    is the segment under the robot's leftmost point and ``hi_x`` its right end [m]. When a
    corner is further, horizontally, from both ends of its segment than the disc's radius and
    its depth, no other segment can be nearer, so it goes straight out along the segment's
    normal (the usual case). Otherwise the two neighbours on
    each side are searched for the nearest ground point, so that a disc rolls over a crest and
    steep walls and step risers push sideways, not up.
    """
    xs = ground.xs
    ys = ground.ys
    nxs = ground.nx
    nys = ground.ny
    n = ground.n
    contact = scratch.contact
    segment = scratch.segment
    mu = params.friction
    radius = params.radius
    clear = highest_ground(xs, ys, n, first, hi_x) + radius + CONTACT_TOLERANCE
    for p in range(robot.n_points):
        x = pos[p, 0]
        y = pos[p, 1]
        if y >= clear:
            contact[p] = False
            continue
        i = segment_near(xs, n, x, segment[p])
        segment[p] = i
        t = (x - xs[i]) / (xs[i + 1] - xs[i])
        gap = y - (ys[i] + t * (ys[i + 1] - ys[i]))
        nx = nxs[i]
        ny = nys[i]
        if min(x - xs[i], xs[i + 1] - x) >= max(radius, -gap):
            depth = radius - ((x - xs[i]) * nx + (y - ys[i]) * ny)
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
                    nx = nxs[j]
                    ny = nys[j]
            distance = math.sqrt(best)
            if distance > 1e-9:
                # Out of the ground along the line from the nearest ground point (towards the
                # corner when it is above ground, away from it when below).
                side = 1.0 if gap >= 0.0 else -1.0
                nx = side * (x - cx) / distance
                ny = side * (y - cy) / distance
                depth = radius - side * distance
            else:
                depth = radius
        contact[p] = depth > -CONTACT_TOLERANCE
        if depth <= 0.0:
            continue
        pos[p, 0] = x + depth * nx
        pos[p, 1] = y + depth * ny
        _bounce_off(p, vel, nx, ny, mu)


@njit(inline="always")
def side_contact(robot, ground, scratch, pos, vel, first, hi_x, lo_y, params):
    """Keep terrain vertices out of the robot's outer sides; Coulomb friction, no bounce.

    Together with :func:`ground_contact` (corners against terrain segments) this makes the
    robot's whole outline a solid surface: it rests on a crest with a side, not only with a
    point, as the original's rigid corner squares do. A vertex may sink ``max_peak_depth``
    into a side before it is pushed out. A vertex behind several sides belongs to the shallowest
    one only. The push and the impulses act at the contact point, a fraction
    ``lam`` along side a -> b, shared by a and b as a rigid side would share them (each end
    in proportion to how much it moves that point and to its inverse mass), so that they
    exert no torque about the contact point.
    """
    boundary = robot.boundary
    inv_mass = robot.inv_mass
    contact = scratch.contact
    xs = ground.xs
    ys = ground.ys
    n = ground.n
    limit = params.peak_depth
    mu = params.friction
    radius = params.radius
    reach = MAX_SIDE_DEPTH + radius
    for i in range(first + 1, n - 1):
        tx = xs[i]
        if tx > hi_x + radius:
            break
        ty = ys[i]
        if ty <= lo_y - radius:
            continue  # below every corner's disc: it cannot touch the robot
        side = -1
        depth = 0.0
        lam = 0.0
        for q in range(robot.n_boundary):
            a = boundary[q, 0]
            b = boundary[q, 1]
            # A vertex that can count for this side lies in its bounding box grown by reach:
            # two comparisons spare most sides the division and the square root.
            if (tx < min(pos[a, 0], pos[b, 0]) - reach or tx > max(pos[a, 0], pos[b, 0]) + reach
                    or ty < min(pos[a, 1], pos[b, 1]) - reach
                    or ty > max(pos[a, 1], pos[b, 1]) + reach):
                continue
            ex = pos[b, 0] - pos[a, 0]
            ey = pos[b, 1] - pos[a, 1]
            length2 = ex * ex + ey * ey
            at = ((tx - pos[a, 0]) * ex + (ty - pos[a, 1]) * ey) / length2
            if at <= 0.0 or at >= 1.0:
                continue
            # How deep the vertex is behind the side's outward normal (ey, -ex) / length.
            d = radius - ((tx - pos[a, 0]) * ey - (ty - pos[a, 1]) * ex) / math.sqrt(length2)
            if d <= -CONTACT_TOLERANCE or d >= reach:
                continue
            if side < 0 or d < depth:
                side = q
                depth = d
                lam = at
        if side < 0 or depth <= limit - CONTACT_TOLERANCE:
            continue
        a = boundary[side, 0]
        b = boundary[side, 1]
        contact[a] = True
        contact[b] = True
        if depth <= limit:
            continue
        ex = pos[b, 0] - pos[a, 0]
        ey = pos[b, 1] - pos[a, 1]
        inv = 1.0 / math.sqrt(ex * ex + ey * ey)
        tx_ = ex * inv
        ty_ = ey * inv
        nx = ty_  # outward normal
        ny = -tx_
        wa = (1.0 - lam) * inv_mass[a]
        wb = lam * inv_mass[b]
        share = 1.0 / ((1.0 - lam) * wa + lam * wb)  # effective mass at the contact point
        push = (depth - limit) * share
        pos[a, 0] -= nx * push * wa
        pos[a, 1] -= ny * push * wa
        pos[b, 0] -= nx * push * wb
        pos[b, 1] -= ny * push * wb
        # The side's velocity at the contact point, along the normal into the vertex (> 0
        # closes) and along the side.
        vx = (1.0 - lam) * vel[a, 0] + lam * vel[b, 0]
        vy = (1.0 - lam) * vel[a, 1] + lam * vel[b, 1]
        vn = vx * nx + vy * ny
        if vn <= 0.0:
            continue
        vt = vx * tx_ + vy * ty_
        cut = min(abs(vt), mu * vn)
        if vt < 0.0:
            cut = -cut
        jx = (vn * nx + cut * tx_) * share
        jy = (vn * ny + cut * ty_) * share
        vel[a, 0] -= jx * wa
        vel[a, 1] -= jy * wa
        vel[b, 0] -= jx * wb
        vel[b, 1] -= jy * wb


@njit(inline="always")
def voxel_corners(corners, v):
    """Point indices of voxel ``v``'s corners: SW, SE, NE, NW (counter-clockwise)."""
    return corners[v, 0], corners[v, 1], corners[v, 2], corners[v, 3]


@njit(inline="always")
def keep_orientation(robot, pos, vel):
    """No voxel turns inside out: each voxel's signed area stays at least ``min_area``.

    Length limits cannot do it (a mirrored voxel has the same side and diagonal lengths).
    The check is inlined; the rare correction (:func:`restore_area`) is not, which keeps the
    substep's code small.
    """
    corners = robot.corners
    min_area = robot.min_area
    for v in range(robot.n_voxels):
        sw, se, ne, nw = voxel_corners(corners, v)
        # Twice the signed area: the cross product of the diagonals.
        d1x = pos[ne, 0] - pos[sw, 0]
        d1y = pos[ne, 1] - pos[sw, 1]
        d2x = pos[nw, 0] - pos[se, 0]
        d2y = pos[nw, 1] - pos[se, 1]
        if 0.5 * (d1x * d2y - d1y * d2x) < min_area:
            restore_area(sw, se, ne, nw, min_area, robot.inv_mass, pos, vel)


@njit(_nrt=False)
def restore_area(sw, se, ne, nw, min_area, inv_mass, pos, vel):
    """Move the corners of a voxel smaller than ``min_area`` along its area's gradient,
    weighted by inverse mass, to restore ``min_area``, and remove the corners' shrinking
    rate along it."""
    d1x = pos[ne, 0] - pos[sw, 0]
    d1y = pos[ne, 1] - pos[sw, 1]
    d2x = pos[nw, 0] - pos[se, 0]
    d2y = pos[nw, 1] - pos[se, 1]
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
    rate = (g_sw_x * vel[sw, 0] + g_sw_y * vel[sw, 1] + g_ne_x * vel[ne, 0]
            + g_ne_y * vel[ne, 1] + g_se_x * vel[se, 0] + g_se_y * vel[se, 1]
            + g_nw_x * vel[nw, 0] + g_nw_y * vel[nw, 1])
    stop = max(0.0, -rate) / norm
    for p, gx, gy, w in ((sw, g_sw_x, g_sw_y, w_sw), (se, g_se_x, g_se_y, w_se),
                         (ne, g_ne_x, g_ne_y, w_ne), (nw, g_nw_x, g_nw_y, w_nw)):
        pos[p, 0] += step * w * gx
        pos[p, 1] += step * w * gy
        vel[p, 0] += stop * w * gx
        vel[p, 1] += stop * w * gy


@njit(inline="always")
def substep(robot, ground, scratch, pos, vel, params):
    """Advance one robot by one physics substep: springs, gravity and drag; the voxels'
    length and orientation limits; contact of the outline with the terrain."""
    integrate(robot, scratch, pos, vel, params)
    keep_orientation(robot, pos, vel)
    lo_x, hi_x, lo_y = extent(robot.n_points, pos)
    segment = scratch.segment
    first = segment_near(ground.xs, ground.n, lo_x - params.radius, segment[robot.n_points])
    segment[robot.n_points] = first
    ground_contact(robot, ground, scratch, pos, vel, first, hi_x + params.radius, params)
    side_contact(robot, ground, scratch, pos, vel, first, hi_x, lo_y, params)


@njit(_nrt=False)
def advance(robot, ground, scratch, pos, vel, params, substeps):
    """One control step of physics: ``substeps`` substeps under the rest lengths of
    ``scratch.rest``, then the length limits, so that what is sensed obeys them.

    Compiled without Numba's reference counting (``_nrt=False``: nothing here allocates), as
    every field read from the per-robot tuples would otherwise cost an atomic increment and
    decrement on each substep.
    """
    for _ in range(substeps):
        substep(robot, ground, scratch, pos, vel, params)
    enforce_min_lengths(robot.n_springs, robot.ends, robot.min_length, robot.inv_mass, pos, vel)
