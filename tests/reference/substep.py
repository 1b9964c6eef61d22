"""A slow NumPy oracle of one physics substep of the rigid-block model, written from the
documented model.

It follows the docstrings of somite.sim.physics, robot.py and system.py (the model of the
authors' 2D-VSR-Sim: one rigid corner body per lattice point, joined by springs), not the
kernels' code: plain loops over springs, ropes, voxels, outline vertices and terrain vertices,
every quantity computed the textbook way (rotation matrices, the shoelace area, rigid-body
impulses, the nearest point of a segment by projection). What it takes from somite is data
only: the robot's static arrays (from ``compile_system``), the settings (``SimConfig``) and a
few named constants.

State: ``pos`` (P, 3) holds each body's centre of mass and angle, ``vel`` (P, 3) its velocity
and angular velocity. The point at offset o (body frame) of body p is at x_p + R(angle_p) o
and moves at v_p + w_p x r with r = R(angle_p) o (in 2-D, w x r = (-w r_y, w r_x)).

A push J along a unit vector n at lever r of body p (an impulse, or the same arithmetic on
positions: a displacement) changes its centre by n J / m_p and its angle by (r x n) J / I_p. It
moves the point at r along n by J w, where w = 1 / m_p + (r x n)^2 / I_p is the body's inverse
mass along n at r; so "move the point by d along n" is the push d / w, to first order (one
linear step, not iterated). A correction takes its levers and directions from the state just
before it acts and keeps them for its velocity part.

One substep:

1. Springs, gravity, drag. Spring s joins its anchor on body a to its anchor on body b; with L
   the anchors' distance, u the unit vector from a's anchor to b's and dL/dt the rate of L, it
   pulls body a with m_s (k (L - rest) + c dL/dt) u at its anchor and body b with the opposite
   force at its own, where m_s is the spring's effective mass, k = (2 pi spring_hz)^2 and
   c = 2 damping_ratio 2 pi spring_hz (all forces and torques from the state at the start of
   the substep). Then semi-implicit Euler: v += (F / m - drag v - g y) dt,
   w += (T / I - drag w) dt, then the centres and angles move by the new rates times dt.
2. Rope limits, one after another, each on the state that the previous ones left: a rope
   whose two block centres are closer than BLOCK_SIDE pushes its two bodies apart along the
   centres' line, as one constraint (the push that closes the shortfall, over the sum of the
   two bodies' inverse masses along the line); if the centres approach each other, that
   closing speed is removed the same way (no bounce).
3. Orientation, voxel after voxel: a voxel whose outline (the lattice points that its corner
   bodies carry) has a signed area below min_area = min_area_ratio x 9 m^2 has its four bodies
   translated (not turned) along the area's gradient, weighted by inverse mass, by the linear
   step that restores min_area; if its lattice points' velocities (each body's v + w x r, r
   the lattice point's world offset from the body's centre: its spin counts) shrink the area
   along that gradient, that rate is removed the same way (by translating the bodies).
4. Contact with the terrain, all found from the state that step 3 left, each corrected as if
   it were its body's only contact; then each body takes the mean of its contacts' position
   corrections over all its contacts, and the mean of their impulses over its approaching
   contacts only (so that the order in which contacts are found does not matter, and a
   contact whose point already leaves the ground dilutes no impulse).

   a. Outline vertices (the blocks' corners on the robot's outline) against the terrain
      segments. gap: the vertex's height above the ground straight under it. gap <
      CONTACT_TOLERANCE: its body touches the ground. gap < 0: a contact; if the vertex is
      farther horizontally from both ends of its segment than it is deep (-gap), it is pushed
      along the segment's normal by its distance to the segment's line; otherwise towards the
      nearest point of the five segments around it (its own and two on each side), by its
      distance to that point (so that a step's riser pushes sideways).
   b. Terrain vertices against the outline blocks: a terrain vertex strictly inside a block
      is a contact; the block moves away from it through the block's edge nearest to it
      (+x, -x, +y, -y of the block's frame, the first of equals), by the vertex's distance to
      that edge; the block's body touches the ground.

   One contact at point q, depth d, normal n (the direction the body must go), tangent
   t = (n_y, -n_x): the body moves so that q moves by d along n. If q approaches the ground
   (its speed along n, v_n < 0), the ground gives it an impulse j_n n + j_t t. K, the 2 x 2
   matrix of how an impulse along n or t changes q's velocity along n and t (through the
   body's mass and inertia: the two are coupled, as each impulse also turns the body), gives
   the impulse that leaves q with normal speed -e v_n (e = restitution for an impact faster
   than RESTITUTION_SPEED, 0 otherwise) and no sliding: K (j_n, j_t) = (-(1 + e) v_n, -v_t).
   If that has j_n >= 0 and |j_t| <= friction j_n, q sticks. Otherwise it slides at the
   Coulomb limit: j_t = s friction j_n, s the sign of the sticking j_t that was refused (the
   way the impulse that would have stopped q pushes), and j_n from the normal row alone,
   j_n = -(1 + e) v_n / (K_nn + s friction K_nt), whose slope is then positive
   (test_substep_reference.py, test_a_sliding_contact_never_pulls_into_the_ground). Friction
   then opposes the sliding that the impulse leaves (event "slide_reversed" if not: a
   diagnostic, never seen).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from somite.sim.config import BLOCK_SIDE, CONTROL_HZ, VOXEL_SIDE, SimConfig
from somite.sim.physics import CONTACT_TOLERANCE, RESTITUTION_SPEED

HALF_BLOCK = BLOCK_SIDE / 2


@dataclass
class Model:
    """One robot of a system and its terrain, with the constants of one configuration.
    Offsets in metres from a body's centre of mass, in the body's frame."""

    mass: np.ndarray  # (P,)
    inertia: np.ndarray  # (P,)
    corner_offset: np.ndarray  # (P, 2) the lattice point that each body carries
    ends: np.ndarray  # (S, 2) bodies a, b of each spring
    anchor: np.ndarray  # (S, 4) anchor on a, anchor on b
    spring_mass: np.ndarray  # (S,)
    owner: np.ndarray  # (S,) the voxel whose actuation sets the rest length
    across: np.ndarray  # (S, 2) lattice point of b minus lattice point of a, at rest
    inset: np.ndarray  # (S, 2) (anchor b - lattice point b) - (anchor a - lattice point a)
    rope_ends: np.ndarray  # (Y, 2)
    rope_anchor: np.ndarray  # (Y, 4) the two block centres
    corners: np.ndarray  # (V, 4) SW, SE, NE, NW
    tip_body: np.ndarray  # (F,)
    tip_offset: np.ndarray  # (F, 2)
    block_body: np.ndarray  # (Q,)
    block_offset: np.ndarray  # (Q, 2) the block's centre
    xs: np.ndarray  # (K,) terrain vertices
    ys: np.ndarray
    dt: float
    stiffness: float  # k per kg of a spring's effective mass
    damping: float  # c per kg
    gravity: float
    drag: float
    friction: float
    restitution: float
    contract: float  # voxel side scale at actuation +1
    expand: float  # at -1
    min_area: float  # [m^2]


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
    n_ropes = int(system.n_ropes[b])
    ends = system.spring_ends[b, :n_springs]
    anchor = system.spring_anchor[b, :n_springs]
    # The robot as built: the bodies unturned at their initial centres, each carrying its
    # lattice point. A spring's anchors sit at fixed offsets from their own lattice points
    # (the blocks do not change when the voxel does), which is all rest_lengths needs.
    centre = system.initial_pos[b, :n_points]
    corner_offset = system.corner_offset[b, :n_points]
    lattice = centre + corner_offset
    anchor_a = centre[ends[:, 0]] + anchor[:, :2]
    anchor_b = centre[ends[:, 1]] + anchor[:, 2:]
    omega = 2.0 * math.pi * config.spring_hz
    t = int(system.terrain_of[b])
    n_terrain = int(system.terrain_n[t])
    n_tips = int(system.n_tips[b])
    n_blocks = int(system.n_blocks[b])
    return Model(
        mass=system.mass[b, :n_points],
        inertia=system.inertia[b, :n_points],
        corner_offset=corner_offset,
        ends=ends,
        anchor=anchor,
        spring_mass=system.spring_mass[b, :n_springs],
        owner=system.spring_owner[b, :n_springs],
        across=lattice[ends[:, 1]] - lattice[ends[:, 0]],
        inset=(anchor_b - lattice[ends[:, 1]]) - (anchor_a - lattice[ends[:, 0]]),
        rope_ends=system.rope_ends[b, :n_ropes],
        rope_anchor=system.rope_anchor[b, :n_ropes],
        corners=system.voxel_corners[b, : system.n_voxels[b]],
        tip_body=system.tip_body[b, :n_tips],
        tip_offset=system.tip_offset[b, :n_tips],
        block_body=system.block_body[b, :n_blocks],
        block_offset=system.block_offset[b, :n_blocks],
        xs=system.terrain_x[t, :n_terrain],
        ys=system.terrain_y[t, :n_terrain],
        dt=1.0 / (CONTROL_HZ * config.substeps),
        stiffness=omega**2,
        damping=2.0 * config.damping_ratio * omega,
        gravity=config.gravity,
        drag=config.drag,
        friction=config.friction,
        restitution=config.restitution,
        contract=math.sqrt(1.0 - config.area_delta),
        expand=math.sqrt(1.0 + config.area_delta),
        min_area=config.min_area_ratio * VOXEL_SIDE**2,
    )


def rest_lengths(m: Model, actuation: np.ndarray) -> np.ndarray:
    """Spring rest lengths under ``actuation`` (one value per voxel, clipped to [-1, 1]): a
    spring's length in its voxel at rest, moved linearly in |a| towards its length in the
    voxel scaled to side ``contract`` x 3 m (a = +1) or ``expand`` x 3 m (a = -1).

    A voxel scaled by s about its centre moves its lattice points apart by s times as much
    while each block stays the same and follows its own lattice point, so a spring's length
    there is |s (lattice b - lattice a) + (anchors' offsets from their lattice points)|."""
    rest = np.empty(len(m.ends))
    for s in range(len(m.ends)):
        a = min(1.0, max(-1.0, float(actuation[m.owner[s]])))
        at_rest = _length_in_scaled_voxel(m, s, 1.0)
        target = _length_in_scaled_voxel(m, s, m.contract if a >= 0.0 else m.expand)
        rest[s] = at_rest + abs(a) * (target - at_rest)
    return rest


def _length_in_scaled_voxel(m: Model, s: int, scale: float) -> float:
    d = scale * m.across[s] + m.inset[s]
    return math.hypot(d[0], d[1])


def substep(m: Model, pos: np.ndarray, vel: np.ndarray, rest: np.ndarray,
            events: Events | None = None):
    """One substep from (pos, vel): the new positions, velocities and contact flags."""
    events = events if events is not None else Events()
    pos = np.array(pos, dtype=np.float64)
    vel = np.array(vel, dtype=np.float64)
    _springs_gravity_drag(m, pos, vel, rest)
    _ropes(m, pos, vel, events)
    _orientation(m, pos, vel, events)
    contact = _contacts(m, pos, vel, events)
    return pos, vel, contact


# Rigid-body arithmetic -------------------------------------------------------------------


def rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def lever(pos, p, offset) -> np.ndarray:
    """Offset ``offset`` (body frame) of body p, turned into the world frame."""
    return rotation(pos[p, 2]) @ np.asarray(offset, dtype=np.float64)


def point_velocity(v, r) -> np.ndarray:
    """Velocity of the point at lever r (world frame, from the centre) of a body whose
    velocity and angular velocity are ``v`` (3,)."""
    return v[:2] + v[2] * np.array([-r[1], r[0]])


def inverse_mass(m, p, r, n) -> float:
    """Inverse mass of body p along unit n at lever r."""
    return 1.0 / m.mass[p] + cross(r, n) ** 2 / m.inertia[p]


def push(m, p, state, r, n, amount) -> None:
    """Push ``amount`` along n at lever r of body p: an impulse if ``state`` is its velocity
    (3,), a displacement if it is its position (3,)."""
    state[:2] += n * amount / m.mass[p]
    state[2] += cross(r, n) * amount / m.inertia[p]


# The steps of a substep (the module docstring) ------------------------------------------


def _springs_gravity_drag(m, pos, vel, rest):
    force = np.zeros((len(pos), 3))  # force x, y and torque on each body
    for s, (a, b) in enumerate(m.ends):
        ra = lever(pos, a, m.anchor[s, :2])
        rb = lever(pos, b, m.anchor[s, 2:])
        d = (pos[b, :2] + rb) - (pos[a, :2] + ra)
        length = math.hypot(d[0], d[1])
        u = d / length
        rate = (point_velocity(vel[b], rb) - point_velocity(vel[a], ra)) @ u
        # On body a, towards b when the spring is stretched or lengthening.
        pull = m.spring_mass[s] * (m.stiffness * (length - rest[s]) + m.damping * rate) * u
        force[a, :2] += pull
        force[a, 2] += cross(ra, pull)
        force[b, :2] -= pull
        force[b, 2] -= cross(rb, pull)
    for p in range(len(pos)):
        vel[p, 0] += (force[p, 0] / m.mass[p] - m.drag * vel[p, 0]) * m.dt
        vel[p, 1] += (force[p, 1] / m.mass[p] - m.drag * vel[p, 1] - m.gravity) * m.dt
        vel[p, 2] += (force[p, 2] / m.inertia[p] - m.drag * vel[p, 2]) * m.dt
    pos += vel * m.dt


def _ropes(m, pos, vel, events):
    for y, (a, b) in enumerate(m.rope_ends):
        ra = lever(pos, a, m.rope_anchor[y, :2])
        rb = lever(pos, b, m.rope_anchor[y, 2:])
        d = (pos[b, :2] + rb) - (pos[a, :2] + ra)
        distance = math.hypot(d[0], d[1])
        if distance >= BLOCK_SIDE:
            continue
        events.add("rope")
        n = d / distance  # from a's block centre to b's
        w = inverse_mass(m, a, ra, n) + inverse_mass(m, b, rb, n)
        apart = (BLOCK_SIDE - distance) / w
        push(m, a, pos[a], ra, n, -apart)
        push(m, b, pos[b], rb, n, apart)
        closing = (point_velocity(vel[b], rb) - point_velocity(vel[a], ra)) @ n
        if closing < 0.0:
            events.add("rope_closing")
            push(m, a, vel[a], ra, n, closing / w)
            push(m, b, vel[b], rb, n, -closing / w)


def lattice_points(m, pos, quad) -> np.ndarray:
    """(4, 2) the lattice points carried by the bodies of ``quad``."""
    return np.array([pos[p, :2] + lever(pos, p, m.corner_offset[p]) for p in quad])


def signed_area(points) -> float:
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _orientation(m, pos, vel, events):
    for quad in m.corners:
        points = lattice_points(m, pos, quad)
        area = signed_area(points)
        if area >= m.min_area:
            continue
        events.add("orientation")
        x, y = points[:, 0], points[:, 1]
        # dA / d(point k) of the shoelace area: half the perpendicular of (next - previous).
        grad = 0.5 * np.stack([np.roll(y, -1) - np.roll(y, 1), np.roll(x, 1) - np.roll(x, -1)],
                              axis=1)
        weight = (1.0 / m.mass[quad])[:, None]
        norm = float(np.sum(weight * grad * grad))
        # Moving a body moves its lattice point by as much: the step is along the gradient.
        pos[quad, :2] += (m.min_area - area) / norm * weight * grad
        # The lattice points' velocities: the bodies' motion and spin (levers from before the
        # step, which only translated the bodies).
        moving = np.array([point_velocity(vel[p], lever(pos, p, m.corner_offset[p]))
                           for p in quad])
        rate = float(np.sum(grad * moving))
        if rate < 0.0:
            events.add("orientation_shrinking")
            if float(np.sum(grad * vel[quad, :2])) >= 0.0:
                events.add("orientation_spin")  # collapsing only through the bodies' spin
            vel[quad, :2] += -rate / norm * weight * grad


def segment_under(m, x) -> int:
    """Index j of the terrain segment [x_j, x_j+1) under x (the end ones beyond the ends)."""
    j = int(np.searchsorted(m.xs, x, side="right")) - 1
    return min(max(j, 0), len(m.xs) - 2)


def nearest_on_segment(m, j, point) -> np.ndarray:
    start = np.array([m.xs[j], m.ys[j]])
    along = np.array([m.xs[j + 1], m.ys[j + 1]]) - start
    u = min(1.0, max(0.0, (point - start) @ along / (along @ along)))
    return start + u * along


def _contacts(m, pos, vel, events) -> np.ndarray:
    """Step 4: the contact flags; ``pos`` and ``vel`` take each body's mean correction."""
    contact = np.zeros(len(pos), dtype=bool)
    pushes = [[] for _ in range(len(pos))]  # per body: position corrections, all contacts
    impulses = [[] for _ in range(len(pos))]  # velocity corrections, approaching contacts
    found = list(_outline_vertices(m, pos, contact, events))
    found += list(_terrain_vertices(m, pos, contact, events))
    for p, point, normal, depth in found:
        dpos, dvel = _correction(m, pos, vel, p, point, normal, depth, events)
        pushes[p].append(dpos)
        if dvel is not None:
            impulses[p].append(dvel)
    for p in range(len(pos)):
        if pushes[p]:
            pos[p] += np.mean(pushes[p], axis=0)
        if impulses[p]:
            vel[p] += np.mean(impulses[p], axis=0)
    return contact


def _outline_vertices(m, pos, contact, events):
    """Step 4a: (body, contact point, normal, depth) of each outline vertex under the
    ground; sets the flags of the bodies that touch it."""
    n_segments = len(m.xs) - 1
    for f, p in enumerate(m.tip_body):
        point = pos[p, :2] + lever(pos, p, m.tip_offset[f])
        j = segment_under(m, point[0])
        x0, y0, x1, y1 = m.xs[j], m.ys[j], m.xs[j + 1], m.ys[j + 1]
        gap = point[1] - (y0 + (point[0] - x0) / (x1 - x0) * (y1 - y0))
        if gap < CONTACT_TOLERANCE:
            contact[p] = True
        if gap >= 0.0:
            if gap < CONTACT_TOLERANCE:
                events.add("tip_touching")  # touching, not under: nothing to push
            continue
        if min(point[0] - x0, x1 - point[0]) >= -gap:
            events.add("tip_straight")
            normal = np.array([-(y1 - y0), x1 - x0]) / math.hypot(x1 - x0, y1 - y0)
            depth = -gap * normal[1]  # the distance to the segment's line
        else:
            events.add("tip_nearest")
            candidates = [nearest_on_segment(m, k, point)
                          for k in range(max(0, j - 2), min(n_segments - 1, j + 2) + 1)]
            distances = [math.hypot(*(q - point)) for q in candidates]
            k = int(np.argmin(distances))  # the first of equals
            nearest, depth = candidates[k], distances[k]
            if depth < 1e-9:
                continue  # on the ground's surface: no direction to push along, nothing to do
            normal = (nearest - point) / depth
        yield p, point, normal, depth


def _terrain_vertices(m, pos, contact, events):
    """Step 4b: (body, contact point, normal, depth) of each terrain vertex inside an outline
    block; sets the flags of those blocks' bodies."""
    centres = np.array([pos[p, :2] + lever(pos, p, o)
                        for p, o in zip(m.block_body, m.block_offset)])
    # A shortcut that changes nothing: a vertex farther (in x or in y) from every block's
    # centre than half a block's diagonal is inside no block.
    reach = HALF_BLOCK * math.sqrt(2.0)
    lo = centres.min(axis=0) - reach
    hi = centres.max(axis=0) + reach
    for vertex in zip(m.xs, m.ys):
        vertex = np.array(vertex)
        if np.any(vertex < lo) or np.any(vertex > hi):
            continue
        for q, p in enumerate(m.block_body):
            turn = rotation(pos[p, 2])
            local = turn.T @ (vertex - centres[q])  # the vertex in the block's frame
            if not (abs(local[0]) < HALF_BLOCK and abs(local[1]) < HALF_BLOCK):
                continue
            events.add("vertex_inside")
            # The vertex's distance to the +x, -x, +y and -y edges, and each edge's outward
            # normal (block frame); the block moves against the normal of the nearest edge.
            exits = ((HALF_BLOCK - local[0], (1.0, 0.0)), (HALF_BLOCK + local[0], (-1.0, 0.0)),
                     (HALF_BLOCK - local[1], (0.0, 1.0)), (HALF_BLOCK + local[1], (0.0, -1.0)))
            depth, outward = min(exits, key=lambda e: e[0])  # the first of equals
            contact[p] = True
            yield p, vertex, -(turn @ np.array(outward)), depth


def response(m, p, r, direction) -> np.ndarray:
    """Change of the velocity of the point at lever r of body p per unit impulse along the
    unit ``direction`` applied there."""
    change = np.zeros(3)
    push(m, p, change, r, direction, 1.0)
    return point_velocity(change, r)


def _correction(m, pos, vel, p, point, normal, depth, events):
    """What one contact alone would change in body p's position (3,) and velocity (3,; None
    if the point does not approach the ground): the point ``point`` is ``depth`` inside the
    ground, which pushes along the unit ``normal`` (the module docstring, step 4)."""
    dpos = np.zeros(3)
    r = point - pos[p, :2]
    push(m, p, dpos, r, normal, depth / inverse_mass(m, p, r, normal))
    v = point_velocity(vel[p], r)
    vn = float(v @ normal)
    if vn >= 0.0:
        events.add("separating")
        return dpos, None
    fast = vn < -RESTITUTION_SPEED
    events.add("bounce" if fast else "no_bounce")
    tangent = np.array([normal[1], -normal[0]])
    vt = float(v @ tangent)
    want_n = -(1.0 + (m.restitution if fast else 0.0)) * vn
    directions = (normal, tangent)
    k = np.array([[response(m, p, r, along) @ seen for along in directions]
                  for seen in directions])  # k[i, j]: along directions[i], per unit along j
    jn, jt = np.linalg.solve(k, [want_n, -vt])
    if jn >= 0.0 and abs(jt) <= m.friction * jn:
        events.add("stick")
    else:
        side = 1.0 if jt > 0.0 else -1.0
        slope = k[0, 0] + side * m.friction * k[0, 1]
        assert slope > 0.0, "friction at its limit would pull the point into the ground"
        events.add("slide")
        jn = want_n / slope
        jt = side * m.friction * jn
        # Does friction at its limit oppose the sliding it leaves (a diagnostic)?
        after = vt + k[1, 0] * jn + k[1, 1] * jt
        if side * after > 0.0:
            events.add("slide_reversed")
    dvel = np.zeros(3)
    push(m, p, dvel, r, normal, jn)
    push(m, p, dvel, r, tangent, jt)
    return dpos, dvel
