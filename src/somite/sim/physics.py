"""Physics of one robot: damped springs, gravity, drag, hard limits and terrain contact.

Every function here works on one robot's arrays (points ``pos``, ``vel`` of shape (P, 2)) and
is called from the episode loop of :mod:`somite.tasks.episode`; the batch kernel runs that loop
for each robot on its own thread. The integrator is semi-implicit (symplectic) Euler: velocities
first from the forces, then positions from the new velocities, then the hard constraints
(length limits, terrain) act on positions and velocities (decisions.md).
"""

from __future__ import annotations

import math

from .._jit import njit
from .config import (
    P_CONTRACT,
    P_DAMPING,
    P_DRAG,
    P_DT,
    P_EXPAND,
    P_FRICTION,
    P_GRAVITY,
    P_MIN_LENGTH,
    P_PEAK_DEPTH,
    P_STIFFNESS,
)

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


@njit
def set_rest_lengths(n_springs, owners, rest0, actuation, params, rest):
    """Rest length of each spring for the voxels' current actuation (mean over its owners)."""
    contract = params[P_CONTRACT]
    expand = params[P_EXPAND]
    for s in range(n_springs):
        f = rest_length_factor(actuation[owners[s, 0]], contract, expand)
        if owners[s, 1] >= 0:
            f = 0.5 * (f + rest_length_factor(actuation[owners[s, 1]], contract, expand))
        rest[s] = rest0[s] * f


@njit
def integrate(n_points, n_springs, ends, strength, rest, mass, inv_mass, pos, vel, force, params):
    """One semi-implicit Euler step of springs, gravity and drag.

    ``strength`` is the number of voxels owning each spring (1 or 2): parallel springs add up.
    """
    dt = params[P_DT]
    k = params[P_STIFFNESS]
    c = params[P_DAMPING]
    g = params[P_GRAVITY]
    drag = params[P_DRAG]
    for p in range(n_points):
        force[p, 0] = -drag * mass[p] * vel[p, 0]
        force[p, 1] = -drag * mass[p] * vel[p, 1] - g * mass[p]
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        dx = pos[b, 0] - pos[a, 0]
        dy = pos[b, 1] - pos[a, 1]
        length = math.sqrt(dx * dx + dy * dy)
        if length < 1e-9:
            continue
        inv = 1.0 / length
        nx = dx * inv
        ny = dy * inv
        closing = (vel[b, 0] - vel[a, 0]) * nx + (vel[b, 1] - vel[a, 1]) * ny
        f = strength[s] * (k * (length - rest[s]) + c * closing)
        force[a, 0] += f * nx
        force[a, 1] += f * ny
        force[b, 0] -= f * nx
        force[b, 1] -= f * ny
    for p in range(n_points):
        step = inv_mass[p] * dt
        vel[p, 0] += force[p, 0] * step
        vel[p, 1] += force[p, 1] * step
        pos[p, 0] += vel[p, 0] * dt
        pos[p, 1] += vel[p, 1] * dt


@njit
def enforce_min_lengths(n_springs, ends, rest0, mass, pos, vel, params):
    """Hard limit: no side or diagonal shorter than ``min_length_ratio`` of its rest length.

    A violating pair is pushed apart (mass-weighted) onto the limit and its closing velocity
    along the spring removed, so no controller can collapse or invert a voxel.
    """
    ratio = params[P_MIN_LENGTH]
    for s in range(n_springs):
        a = ends[s, 0]
        b = ends[s, 1]
        dx = pos[b, 0] - pos[a, 0]
        dy = pos[b, 1] - pos[a, 1]
        limit = ratio * rest0[s]
        d2 = dx * dx + dy * dy
        if d2 >= limit * limit:
            continue
        length = math.sqrt(d2)
        if length < 1e-9:
            continue
        nx = dx / length
        ny = dy / length
        wa = 1.0 / mass[a]
        wb = 1.0 / mass[b]
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


@njit
def segment_at(xs, n, x) -> int:
    """Index i of the terrain segment [xs[i], xs[i+1]] under x (clamped to the terrain)."""
    lo = 0
    hi = n - 2
    if x <= xs[0]:
        return 0
    if x >= xs[n - 1]:
        return n - 2
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid - 1
    return lo


@njit
def height_at(xs, ys, n, x) -> float:
    """Ground height under x."""
    i = segment_at(xs, n, x)
    t = (x - xs[i]) / (xs[i + 1] - xs[i])
    return ys[i] + t * (ys[i + 1] - ys[i])


@njit
def highest_ground(xs, ys, n, lo_x, hi_x) -> float:
    """The highest terrain point between lo_x and hi_x."""
    i = segment_at(xs, n, lo_x)
    top = max(ys[i], ys[i + 1])
    while i + 1 < n - 1 and xs[i + 1] < hi_x:
        i += 1
        top = max(top, ys[i + 1])
    return top


@njit
def x_range(n_points, pos):
    lo_x = pos[0, 0]
    hi_x = pos[0, 0]
    for p in range(1, n_points):
        lo_x = min(lo_x, pos[p, 0])
        hi_x = max(hi_x, pos[p, 0])
    return lo_x, hi_x


@njit
def ground_contact(n_points, pos, vel, contact, xs, ys, n, params):
    """Push corners out of the ground onto its nearest segment; no bounce, Coulomb friction.

    The nearest segment is searched among the two neighbours on each side of the segment under
    the corner, so that steep walls and step risers push sideways, not up.
    """
    mu = params[P_FRICTION]
    lo_x, hi_x = x_range(n_points, pos)
    clear = highest_ground(xs, ys, n, lo_x, hi_x) + CONTACT_TOLERANCE
    for p in range(n_points):
        x = pos[p, 0]
        y = pos[p, 1]
        if y >= clear:
            contact[p] = False
            continue
        i = segment_at(xs, n, x)
        t = (x - xs[i]) / (xs[i + 1] - xs[i])
        gap = y - (ys[i] + t * (ys[i + 1] - ys[i]))
        contact[p] = gap < CONTACT_TOLERANCE
        if gap >= 0.0:
            continue
        best = 1e300
        bx = x
        by = y
        nx = 0.0
        ny = 1.0
        for j in range(max(0, i - 2), min(n - 1, i + 3)):
            sx = xs[j + 1] - xs[j]
            sy = ys[j + 1] - ys[j]
            seg2 = sx * sx + sy * sy
            u = ((x - xs[j]) * sx + (y - ys[j]) * sy) / seg2
            u = min(1.0, max(0.0, u))
            cx = xs[j] + u * sx
            cy = ys[j] + u * sy
            d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy)
            if d2 < best:
                best = d2
                bx = cx
                by = cy
                inv = 1.0 / math.sqrt(seg2)
                nx = -sy * inv
                ny = sx * inv
        pos[p, 0] = bx
        pos[p, 1] = by
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


@njit
def peak_contact(n_points, n_boundary, boundary, pos, vel, xs, ys, n, params):
    """Keep terrain vertices from poking deeper than ``max_peak_depth`` into an outer side.

    Corners alone would let a sharp hilltop pass between two corners 3 m apart.
    """
    limit = params[P_PEAK_DEPTH]
    lo_x, hi_x = x_range(n_points, pos)
    first = segment_at(xs, n, lo_x) + 1
    for i in range(first, n - 1):
        tx = xs[i]
        if tx > hi_x:
            break
        ty = ys[i]
        for q in range(n_boundary):
            a = boundary[q, 0]
            b = boundary[q, 1]
            ex = pos[b, 0] - pos[a, 0]
            ey = pos[b, 1] - pos[a, 1]
            length2 = ex * ex + ey * ey
            lam = ((tx - pos[a, 0]) * ex + (ty - pos[a, 1]) * ey) / length2
            if lam <= 0.0 or lam >= 1.0:
                continue
            inv = 1.0 / math.sqrt(length2)
            onx = ey * inv
            ony = -ex * inv
            depth = -((tx - pos[a, 0]) * onx + (ty - pos[a, 1]) * ony)
            if depth <= limit or depth >= MAX_SIDE_DEPTH:
                continue
            wa = 1.0 - lam
            wb = lam
            scale = (depth - limit) / (wa * wa + wb * wb)
            pos[a, 0] -= onx * scale * wa
            pos[a, 1] -= ony * scale * wa
            pos[b, 0] -= onx * scale * wb
            pos[b, 1] -= ony * scale * wb
            for p in (a, b):
                vn = vel[p, 0] * onx + vel[p, 1] * ony
                if vn > 0.0:
                    vel[p, 0] -= vn * onx
                    vel[p, 1] -= vn * ony


@njit
def substep(n_points, n_springs, n_boundary, ends, strength, rest, rest0, mass, inv_mass,
            boundary, pos, vel, force, contact, xs, ys, n_terrain, params):
    """Advance one robot by one physics substep."""
    integrate(n_points, n_springs, ends, strength, rest, mass, inv_mass, pos, vel, force, params)
    enforce_min_lengths(n_springs, ends, rest0, mass, pos, vel, params)
    peak_contact(n_points, n_boundary, boundary, pos, vel, xs, ys, n_terrain, params)
    ground_contact(n_points, pos, vel, contact, xs, ys, n_terrain, params)
