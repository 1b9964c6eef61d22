"""A slow NumPy oracle of one physics substep, written from the documented model.

It follows decisions.md ("The simulator is ours") and the docstrings of somite.sim.physics,
not the kernels' code: plain loops over springs, voxels, corners and terrain vertices, every
quantity computed the textbook way (shoelace area, nearest point on the whole terrain
polyline, Coulomb friction as a capped tangential impulse). What it takes from somite is data
only: the body's springs, masses, corners and outer sides (system arrays) and the settings.

One substep, in this order:

1. Springs, gravity, drag: each spring pulls its ends with strength * (k (L - rest) + c dL/dt)
   along its direction (strength: voxels owning a side, ``diagonal_stiffness`` for a
   diagonal); the forces are taken at the start of the substep. If any spring is then shorter
   than its hard limit, the limits are enforced first (below), on positions and velocities.
   Then semi-implicit Euler: v += (F / m - drag v - g y) dt, x += v dt.
2. Length limits (only in step 1): each spring in turn, if shorter than its limit, has its
   ends moved apart along it, in inverse proportion to their masses, to exactly the limit,
   and their closing speed along it removed the same way.
3. Orientation: each voxel in turn whose signed area is below ``min_area`` has its corners
   moved along the area's gradient, weighted by inverse mass, by the linear step that
   restores ``min_area``; if its area is shrinking, that rate is removed the same way.
4. Ground: each corner is a disc of radius r = ``contact_radius`` (0: a point). Its signed
   distance s to the ground is the distance to the nearest point of the terrain polyline,
   negative when the centre is under the ground. A corner with s < r + CONTACT_TOLERANCE
   touches the ground; one with s < r moves out to s = r along the line from that nearest
   point (away from it when the centre was under the ground, so that at a terrain vertex the
   normal is the direction of the push, whichever segment it belongs to). If it was moving
   into the ground along that normal, that motion stops and its sliding speed is cut by up
   to mu times the normal speed it lost.
5. Sides, thickened by r: each terrain vertex (left to right) against the outer sides: of the
   sides it lies between the ends of, behind the thickened side by more than
   -CONTACT_TOLERANCE and less than MAX_SIDE_DEPTH (measured from the side itself), the
   shallowest (the first in order among equals) is its side; if it is more than
   ``max_peak_depth`` - CONTACT_TOLERANCE deep there, both the side's ends touch; if deeper
   than ``max_peak_depth`` the side moves along its normal as a rigid rod would under a push
   at the contact point (lam: the point's fraction along the side):
   end a by (1 - lam) w_a, end b by lam w_b (w: inverse masses), scaled so that the contact
   point moves by the excess depth; then the contact point's closing speed stops and its
   sliding is cut by Coulomb friction, the velocity changes shared the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from somite.sim.config import CONTROL_HZ, CORNER_MASS, VOXEL_SIDE, SimConfig
from somite.sim.physics import CONTACT_TOLERANCE, MAX_SIDE_DEPTH


@dataclass
class Model:
    """One robot of a system and its terrain, with the constants of one configuration."""

    ends: np.ndarray
    strength: np.ndarray
    rest0: np.ndarray
    owners: np.ndarray
    min_length: np.ndarray
    mass: np.ndarray
    corners: np.ndarray
    boundary: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    dt: float
    stiffness: float
    damping: float
    gravity: float
    drag: float
    friction: float
    contract: float
    expand: float
    min_area: float
    peak_depth: float
    radius: float


@dataclass
class Events:
    """How often each branch of the model acted (so that a test can tell it was exercised)."""

    counts: dict = field(default_factory=dict)

    def add(self, name: str) -> None:
        self.counts[name] = self.counts.get(name, 0) + 1


def model(system, b: int, config: SimConfig) -> Model:
    """Robot ``b`` of ``system`` under ``config``."""
    n_points = int(system.n_points[b])
    n_springs = int(system.n_springs[b])
    diagonal = system.spring_diagonal[b, :n_springs]
    owners = system.spring_owners[b, :n_springs]
    rest0 = system.spring_rest[b, :n_springs]
    strength = np.where(diagonal, config.diagonal_stiffness,
                        np.where(owners[:, 1] >= 0, 2.0, 1.0))
    ratio = np.where(diagonal, config.min_diagonal_ratio, config.min_side_ratio)
    omega = 2.0 * math.pi * config.spring_hz
    reduced = CORNER_MASS / 2.0  # two corner masses on one spring
    t = int(system.terrain_of[b])
    n_terrain = int(system.terrain_n[t])
    return Model(
        ends=system.spring_ends[b, :n_springs],
        strength=strength,
        rest0=rest0,
        owners=owners,
        min_length=rest0 * ratio,
        mass=system.mass[b, :n_points],
        corners=system.voxel_corners[b, : system.n_voxels[b]],
        boundary=system.boundary[b, : system.n_boundary[b]],
        xs=system.terrain_x[t, :n_terrain],
        ys=system.terrain_y[t, :n_terrain],
        dt=1.0 / (CONTROL_HZ * config.substeps),
        stiffness=reduced * omega**2,
        damping=2.0 * reduced * config.damping_ratio * omega,
        gravity=config.gravity,
        drag=config.drag,
        friction=config.friction,
        contract=math.sqrt(1.0 - config.area_delta),
        expand=math.sqrt(1.0 + config.area_delta),
        min_area=config.min_area_ratio * VOXEL_SIDE**2,
        peak_depth=config.max_peak_depth,
        radius=config.contact_radius,
    )


def rest_lengths(m: Model, actuation: np.ndarray) -> np.ndarray:
    """Spring rest lengths under ``actuation`` (one value per voxel, clipped to [-1, 1]): the
    side scale goes linearly from 1 to ``contract`` (a = 1) or ``expand`` (a = -1); a spring
    owned by two voxels takes the mean of their scales (two parallel springs)."""
    a = np.clip(actuation, -1.0, 1.0)
    scale = np.where(a >= 0.0, 1.0 + a * (m.contract - 1.0), 1.0 - a * (m.expand - 1.0))
    rest = np.empty(len(m.rest0))
    for s, (v, w) in enumerate(m.owners):
        rest[s] = m.rest0[s] * (scale[v] if w < 0 else 0.5 * (scale[v] + scale[w]))
    return rest


def substep(m: Model, pos: np.ndarray, vel: np.ndarray, rest: np.ndarray,
            events: Events | None = None):
    """One substep from (pos, vel): the new positions, velocities and contact flags."""
    events = events or Events()
    pos, vel, contact = before_sides(m, pos, vel, rest, events)
    _sides(m, pos, vel, contact, events)
    return pos, vel, contact


def before_sides(m: Model, pos, vel, rest, events: Events | None = None):
    """Steps 1 to 4 of a substep (all but the side contacts)."""
    events = events or Events()
    pos = np.array(pos, dtype=np.float64)
    vel = np.array(vel, dtype=np.float64)
    _springs_gravity_drag(m, pos, vel, rest, events)
    _orientation(m, pos, vel, events)
    contact = _ground(m, pos, vel, events)
    return pos, vel, contact


def _springs_gravity_drag(m, pos, vel, rest, events):
    force = np.zeros_like(pos)
    any_short = False
    for s, (a, b) in enumerate(m.ends):
        d = pos[b] - pos[a]
        length = math.hypot(d[0], d[1])
        unit = d / length
        stretch_rate = (vel[b] - vel[a]) @ unit
        tension = m.strength[s] * (m.stiffness * (length - rest[s]) + m.damping * stretch_rate)
        force[a] += tension * unit
        force[b] -= tension * unit
        any_short |= length < m.min_length[s]
    if any_short:
        enforce_min_lengths(m, pos, vel, events)
    for p in range(len(pos)):
        acceleration = force[p] / m.mass[p] - m.drag * vel[p] - np.array([0.0, m.gravity])
        vel[p] += acceleration * m.dt
        pos[p] += vel[p] * m.dt


def enforce_min_lengths(m, pos, vel, events=None):
    """Step 2 of the module docstring (also run after each control step's last substep)."""
    inv = 1.0 / m.mass
    for s, (a, b) in enumerate(m.ends):
        d = pos[b] - pos[a]
        length = math.hypot(d[0], d[1])
        if length >= m.min_length[s]:
            continue
        if events:
            events.add("min_length")
        unit = d / length
        total = inv[a] + inv[b]
        gap = m.min_length[s] - length
        pos[a] -= unit * gap * inv[a] / total
        pos[b] += unit * gap * inv[b] / total
        closing = (vel[b] - vel[a]) @ unit
        if closing < 0.0:
            vel[a] += unit * closing * inv[a] / total
            vel[b] -= unit * closing * inv[b] / total


def signed_area(pos, quad) -> float:
    x, y = pos[quad, 0], pos[quad, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _orientation(m, pos, vel, events):
    inv = 1.0 / m.mass
    for quad in m.corners:
        area = signed_area(pos, quad)
        if area >= m.min_area:
            continue
        events.add("orientation")
        x, y = pos[quad, 0], pos[quad, 1]
        grad = np.stack([0.5 * (np.roll(y, -1) - np.roll(y, 1)),
                         0.5 * (np.roll(x, 1) - np.roll(x, -1))], axis=1)  # dA / dp
        weight = inv[quad][:, None]
        norm = float(np.sum(weight * grad * grad))
        rate = float(np.sum(grad * vel[quad]))
        pos[quad] += (m.min_area - area) / norm * weight * grad
        if rate < 0.0:
            vel[quad] += -rate / norm * weight * grad


def _nearest_on_terrain(m, point):
    """Nearest point of the terrain polyline to ``point``, the segment it lies on (the first
    one, left to right, among equally near segments) and whether it is one of its ends."""
    best, where, segment, end = math.inf, None, -1, False
    for j in range(len(m.xs) - 1):
        start = np.array([m.xs[j], m.ys[j]])
        along = np.array([m.xs[j + 1], m.ys[j + 1]]) - start
        u = (point - start) @ along / (along @ along)
        clamped = min(1.0, max(0.0, u))
        candidate = start + clamped * along
        dx, dy = point[0] - candidate[0], point[1] - candidate[1]
        d2 = dx * dx + dy * dy
        if d2 < best:
            best, where, segment, end = d2, candidate, j, clamped != u
    return where, segment, end


def _ground(m, pos, vel, events):
    contact = np.zeros(len(pos), dtype=bool)
    for p in range(len(pos)):
        nearest, j, end = _nearest_on_terrain(m, pos[p])
        offset = pos[p] - nearest
        distance = math.hypot(offset[0], offset[1])
        above = pos[p, 1] >= np.interp(pos[p, 0], m.xs, m.ys)
        signed = distance if above else -distance
        contact[p] = signed < m.radius + CONTACT_TOLERANCE
        if signed >= m.radius:
            continue
        events.add("ground" if not above else "ground_disc")
        if end and distance > 1e-9:
            # At a terrain vertex the normal is the direction of the push, whichever segment
            # the vertex belongs to.
            normal = offset / signed
        else:  # inside a segment the offset is along its normal: take that, exactly
            along = np.array([m.xs[j + 1] - m.xs[j], m.ys[j + 1] - m.ys[j]])
            normal = np.array([-along[1], along[0]]) / math.hypot(along[0], along[1])
        pos[p] = nearest + m.radius * normal
        vn = vel[p] @ normal
        if vn >= 0.0:
            continue
        events.add("ground_impact")
        tangent = np.array([normal[1], -normal[0]])
        vt = vel[p] @ tangent
        kept = math.copysign(max(0.0, abs(vt) - m.friction * -vn), vt)
        if kept != 0.0:
            events.add("ground_slide")
        vel[p] = kept * tangent
    return contact


def _sides(m, pos, vel, contact, events):
    for i in range(1, len(m.xs) - 1):
        vertex = np.array([m.xs[i], m.ys[i]])
        chosen = None
        for a, b in m.boundary:
            side = pos[b] - pos[a]
            length = math.hypot(side[0], side[1])
            along = side / length
            lam = (vertex - pos[a]) @ along / length
            if not 0.0 < lam < 1.0:
                continue
            outward = np.array([along[1], -along[0]])  # the robot is on the side's left
            depth = m.radius - (vertex - pos[a]) @ outward
            if not -CONTACT_TOLERANCE < depth < MAX_SIDE_DEPTH + m.radius:
                continue
            if chosen is None or depth < chosen[0]:
                chosen = (depth, a, b, lam)
        if chosen is None or chosen[0] <= m.peak_depth - CONTACT_TOLERANCE:
            continue
        depth, a, b, lam = chosen
        contact[a] = contact[b] = True
        if depth <= m.peak_depth:
            events.add("side_touch")
            continue
        events.add("side_push")
        side = pos[b] - pos[a]
        along = side / math.hypot(side[0], side[1])
        outward = np.array([along[1], -along[0]])
        share = np.array([(1.0 - lam) / m.mass[a], lam / m.mass[b]])
        # Moving the ends by share * t moves the contact point by ((1 - lam, lam) @ share) t.
        norm = (1.0 - lam) * share[0] + lam * share[1]
        move = -outward * (depth - m.peak_depth) / norm
        pos[a] += share[0] * move
        pos[b] += share[1] * move
        point_velocity = (1.0 - lam) * vel[a] + lam * vel[b]
        closing = point_velocity @ outward
        if closing <= 0.0:
            continue
        sliding = point_velocity @ along
        kept = math.copysign(max(0.0, abs(sliding) - m.friction * closing), sliding)
        change = -(closing * outward + (sliding - kept) * along) / norm
        vel[a] += share[0] * change
        vel[b] += share[1] * change
