"""Static arrays of a batch of robots, padded to the largest robot of the batch.

Axis glossary: B robots, P corner bodies (one per voxel corner of the lattice), S springs,
Y rope limits, V voxels, F outline vertices of the blocks, Q outline blocks, R sensor
readings, T terrains, K terrain vertices. Padding entries are never read: every kernel loop
runs to the robot's own count (``n_points[b]`` and so on), which is why a robot's outcome does
not depend on the other robots of its batch.

Geometry (decisions.md, "The simulator is ours"), as in the original (original-system.md
section 1.2): each voxel corner holds a rigid square block inside its voxel; the blocks of the
voxels that meet at a lattice point are welded into one rigid corner body. A voxel joins its
four blocks with 18 springs anchored on the blocks' corners and centres, and 4 rope limits
keep its adjacent blocks from overlapping.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .body import SENSOR_WIDTH, Body
from .config import BLOCK_INERTIA, BLOCK_SIDE, CORNER_MASS, VOXEL_SIDE
from .terrain import Terrain

# Reading codes: which quantity one scalar reading measures.
R_AREA, R_TOUCH, R_VX, R_VY, R_LIDAR0 = 0, 1, 2, 3, 4
_READING_CODES = {"area": (R_AREA,), "touch": (R_TOUCH,), "velocity": (R_VX, R_VY)}
_READING_CODES["lidar"] = tuple(R_LIDAR0 + k for k in range(SENSOR_WIDTH["lidar"]))

SPRING_SIDE, SPRING_CROSS, SPRING_CENTRAL = 0, 1, 2
"""The original's spring groups (original-system.md section 1.2): each has its own range."""

PLACEMENT_GAP = 1.0
"""Metres between the ground and the robot's lowest voxel at the start."""


class System(NamedTuple):
    """The static description of a batch (shapes after each field, units in brackets).

    Bodies are the robot's corner bodies, one per lattice point, so a body index is also the
    index of the voxel corner that it carries. Offsets are from a body's centre of mass in its
    own frame (at rest the frame is the world's)."""

    n_points: np.ndarray  # (B,) int32 bodies (= lattice points)
    mass: np.ndarray  # (B, P) [kg]
    inertia: np.ndarray  # (B, P) [kg m^2] about the body's centre of mass
    initial_pos: np.ndarray  # (B, P, 2) [m] centres of mass, placed on the robot's terrain
    corner_offset: np.ndarray  # (B, P, 2) [m] the lattice point (the voxels' corner)
    n_springs: np.ndarray  # (B,) int32
    spring_ends: np.ndarray  # (B, S, 2) int32 body indices
    spring_anchor: np.ndarray  # (B, S, 4) [m] offsets of the two anchors (x_a, y_a, x_b, y_b)
    spring_kind: np.ndarray  # (B, S) int32 SPRING_SIDE / SPRING_CROSS / SPRING_CENTRAL
    spring_owner: np.ndarray  # (B, S) int32 voxel whose actuation sets the rest length
    spring_mass: np.ndarray  # (B, S) [kg] effective mass along the spring, at rest
    n_ropes: np.ndarray  # (B,) int32
    rope_ends: np.ndarray  # (B, Y, 2) int32 body indices
    rope_anchor: np.ndarray  # (B, Y, 4) [m] offsets of the two block centres
    n_voxels: np.ndarray  # (B,) int32
    voxel_corners: np.ndarray  # (B, V, 4) int32 points SW, SE, NE, NW (counter-clockwise)
    voxel_x: np.ndarray  # (B, V) grid column of each voxel
    n_tips: np.ndarray  # (B,) int32
    tip_body: np.ndarray  # (B, F) int32 body of each outline vertex of a block
    tip_offset: np.ndarray  # (B, F, 2) [m]
    n_blocks: np.ndarray  # (B,) int32
    block_body: np.ndarray  # (B, Q) int32 body of each block on the outline
    block_offset: np.ndarray  # (B, Q, 2) [m] the block's centre
    n_readings: np.ndarray  # (B,) int32
    reading_code: np.ndarray  # (B, R) int32 R_* codes
    reading_voxel: np.ndarray  # (B, R) int32
    terrain_of: np.ndarray  # (B,) int32 index into the terrain arrays
    terrain_n: np.ndarray  # (T,) int32 vertices of each terrain
    terrain_x: np.ndarray  # (T, K) [m] strictly increasing
    terrain_y: np.ndarray  # (T, K) [m]
    terrain_nx: np.ndarray  # (T, K) unit normal of segment [k, k+1], pointing up out of the
    terrain_ny: np.ndarray  # (T, K) ground (left of the segment's direction)


class Geometry(NamedTuple):
    """One body's corner bodies, springs, ropes and contact outline at rest, before placement.
    Offsets in metres from each corner body's centre of mass."""

    points: np.ndarray  # (P, 2) lattice coordinates in voxel units
    mass: np.ndarray  # (P,)
    inertia: np.ndarray  # (P,)
    centre: np.ndarray  # (P, 2) [m] centre of mass relative to the lattice point
    springs: np.ndarray  # (S, 2)
    anchors: np.ndarray  # (S, 4)
    kinds: np.ndarray  # (S,)
    owners: np.ndarray  # (S,)
    spring_mass: np.ndarray  # (S,)
    ropes: np.ndarray  # (Y, 2)
    rope_anchors: np.ndarray  # (Y, 4)
    corners: np.ndarray  # (V, 4)
    tip_body: np.ndarray  # (F,)
    tip_offset: np.ndarray  # (F, 2)
    block_body: np.ndarray  # (Q,)
    block_offset: np.ndarray  # (Q, 2)


# Where each corner's block lies inside its voxel, and the voxel's sides as pairs of corners
# (index into SW, SE, NE, NW).
_INTO_VOXEL = ((1, 1), (-1, 1), (-1, -1), (1, -1))
_SIDES = ((0, 1), (1, 2), (2, 3), (3, 0))


def _cross(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * by - ay * bx


def _hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Convex hull, counter-clockwise (monotone chain); collinear points dropped."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts
    lower: list = []
    upper: list = []
    for chain, seq in ((lower, pts), (upper, reversed(pts))):
        for p in seq:
            while len(chain) >= 2 and _cross(chain[-1][0] - chain[-2][0],
                                             chain[-1][1] - chain[-2][1],
                                             p[0] - chain[-2][0], p[1] - chain[-2][1]) <= 1e-12:
                chain.pop()
            chain.append(p)
    return lower[:-1] + upper[:-1]


def _on_outline(p, outline) -> bool:
    """Whether point p (metres, at rest) lies on one of the outline's sides."""
    for (ax, ay), (bx, by) in outline:
        if (abs(_cross(bx - ax, by - ay, p[0] - ax, p[1] - ay)) < 1e-9
                and min(ax, bx) - 1e-9 <= p[0] <= max(ax, bx) + 1e-9
                and min(ay, by) - 1e-9 <= p[1] <= max(ay, by) + 1e-9):
            return True
    return False


def _effective_mass(ra, rb, n) -> float:
    """Mass along unit vector n of a spring between anchors ra, rb of two single blocks (offsets
    from each block's centre), as the original computes a joint's stiffness."""
    w = 2.0 / CORNER_MASS + (_cross(*ra, *n) ** 2 + _cross(*rb, *n) ** 2) / BLOCK_INERTIA
    return 1.0 / w


def geometry(body: Body) -> Geometry:
    """Corner bodies, springs, ropes and contact outline of a body, in the body's voxel order.

    Each voxel corner holds a square block of side BLOCK_SIDE inside the voxel; the blocks that
    meet at a lattice point are one rigid body (welded in the original). Each voxel joins its
    four blocks with 18 springs (per side: the inner and the outer facing corners, and the two
    crossings of them; and the two diagonals between block centres) and keeps adjacent blocks
    apart with 4 rope limits between their centres (original-system.md section 1.2).
    """
    voxels = body.shape.voxels
    half = BLOCK_SIDE / 2
    lattice: dict[tuple[int, int], list] = {}
    for x, y in voxels:
        for corner in ((x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)):
            lattice.setdefault(corner, [])
    ordered = sorted(lattice, key=lambda c: (c[1], c[0]))
    index = {c: i for i, c in enumerate(ordered)}
    corners = np.zeros((len(voxels), 4), dtype=np.int32)
    block_of = []  # per voxel, per corner: the block's centre [m, lattice frame]
    sides: dict[frozenset, int] = {}
    for v, (x, y) in enumerate(voxels):
        quad = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)]
        corners[v] = [index[c] for c in quad]
        centres = []
        for c, (ix, iy) in zip(quad, _INTO_VOXEL):
            centre = (VOXEL_SIDE * c[0] + ix * half, VOXEL_SIDE * c[1] + iy * half)
            lattice[c].append(centre)
            centres.append(centre)
        block_of.append(centres)
        for k in range(4):
            key = frozenset((quad[k], quad[(k + 1) % 4]))
            sides[key] = sides.get(key, 0) + 1
    com = np.array([np.mean(lattice[c], axis=0) for c in ordered])
    mass = np.array([CORNER_MASS * len(lattice[c]) for c in ordered])
    inertia = np.array([
        sum(BLOCK_INERTIA + CORNER_MASS * ((bx - com[i, 0]) ** 2 + (by - com[i, 1]) ** 2)
            for bx, by in lattice[c]) for i, c in enumerate(ordered)])

    def offset(i, point):
        return (point[0] - com[i, 0], point[1] - com[i, 1])

    springs, anchors, kinds, owners, spring_mass, ropes, rope_anchors = [], [], [], [], [], [], []
    for v, centres in enumerate(block_of):
        quad = corners[v]
        middle = np.mean(centres, axis=0)
        for ka, kb in _SIDES:
            a, b = int(quad[ka]), int(quad[kb])
            ca, cb = np.array(centres[ka]), np.array(centres[kb])
            u = (cb - ca) / np.linalg.norm(cb - ca)
            w = middle - (ca + cb) / 2
            w = w / np.linalg.norm(w)  # into the voxel
            a_out, a_in = ca + half * u - half * w, ca + half * u + half * w
            b_out, b_in = cb - half * u - half * w, cb - half * u + half * w
            for pa, pb, kind in ((a_in, b_in, SPRING_SIDE), (a_out, b_out, SPRING_SIDE),
                                 (a_out, b_in, SPRING_CROSS), (a_in, b_out, SPRING_CROSS)):
                d = (pb - pa) / np.linalg.norm(pb - pa)
                springs.append((a, b))
                anchors.append(offset(a, pa) + offset(b, pb))
                kinds.append(kind)
                owners.append(v)
                spring_mass.append(_effective_mass(pa - ca, pb - cb, d))
            ropes.append((a, b))
            rope_anchors.append(offset(a, ca) + offset(b, cb))
        for ka, kb in ((3, 1), (2, 0)):  # NW - SE, NE - SW
            a, b = int(quad[ka]), int(quad[kb])
            ca, cb = centres[ka], centres[kb]
            springs.append((a, b))
            anchors.append(offset(a, ca) + offset(b, cb))
            kinds.append(SPRING_CENTRAL)
            owners.append(v)
            spring_mass.append(CORNER_MASS / 2)
    outline = []
    for x, y in voxels:
        quad = [(x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)]
        for k in range(4):
            if sides[frozenset((quad[k], quad[(k + 1) % 4]))] == 1:
                outline.append(tuple((VOXEL_SIDE * c[0], VOXEL_SIDE * c[1])
                                     for c in (quad[k], quad[(k + 1) % 4])))
    tip_body, tip_offset, block_body, block_offset = [], [], [], []
    for i, c in enumerate(ordered):
        outer = []
        for bx, by in lattice[c]:
            square = [(bx + sx * half, by + sy * half) for sx, sy in _INTO_VOXEL]
            if any(_on_outline(p, outline) for p in square):
                block_body.append(i)
                block_offset.append(offset(i, (bx, by)))
                outer.extend(square)
        for p in _hull(outer):
            if _on_outline(p, outline):
                tip_body.append(i)
                tip_offset.append(offset(i, p))
    lattice_m = np.array(ordered, dtype=np.float64) * VOXEL_SIDE
    return Geometry(
        points=np.asarray(ordered, dtype=np.float64),
        mass=mass,
        inertia=inertia,
        centre=com - lattice_m,
        springs=np.asarray(springs, dtype=np.int32),
        anchors=np.asarray(anchors, dtype=np.float64),
        kinds=np.asarray(kinds, dtype=np.int32),
        owners=np.asarray(owners, dtype=np.int32),
        spring_mass=np.asarray(spring_mass, dtype=np.float64),
        ropes=np.asarray(ropes, dtype=np.int32),
        rope_anchors=np.asarray(rope_anchors, dtype=np.float64),
        corners=corners,
        tip_body=np.asarray(tip_body, dtype=np.int32),
        tip_offset=np.asarray(tip_offset, dtype=np.float64).reshape(-1, 2),
        block_body=np.asarray(block_body, dtype=np.int32),
        block_offset=np.asarray(block_offset, dtype=np.float64).reshape(-1, 2),
    )


def place(points: np.ndarray, corners: np.ndarray, terrain: Terrain, gap: float) -> np.ndarray:
    """Rest positions [m] on ``terrain``: left edge ``gap`` right of the left wall's foot
    (1 m in the paper), lowest voxel PLACEMENT_GAP above the ground under its centre
    (original-system.md section 1.6)."""
    pos = points * VOXEL_SIDE
    pos[:, 0] += terrain.start_x + gap - pos[:, 0].min()
    quads = pos[corners]  # (V, 4, 2)
    centre_x = quads[:, :, 0].mean(axis=1)
    clearance = quads[:, :, 1].min(axis=1) - terrain.height_at(centre_x)
    pos[:, 1] += PLACEMENT_GAP - clearance.min()
    return pos


def _readings(body: Body) -> tuple[list[int], list[int]]:
    codes, voxels = [], []
    for reading in body.readings:
        codes.append(_READING_CODES[reading.kind][reading.component])
        voxels.append(reading.voxel)
    return codes, voxels


def pad(rows: Sequence[np.ndarray], tail: tuple, dtype, fill=0) -> np.ndarray:
    """Stack rows of different lengths into (len(rows), longest, *tail), filling with ``fill``."""
    longest = max(1, max((len(r) for r in rows), default=0))
    out = np.full((len(rows), longest) + tail, fill, dtype=dtype)
    for i, row in enumerate(rows):
        if len(row):
            out[i, : len(row)] = row
    return out


def compile_system(
    bodies: Sequence[Body], terrains: Sequence[Terrain], start_gap: float = 1.0
) -> System:
    """Pad a batch: robot b has body ``bodies[b]`` on terrain ``terrains[b]``, its left edge
    ``start_gap`` metres right of the left wall's foot.

    Identical terrain objects are stored once.
    """
    if len(bodies) != len(terrains):
        raise ValueError("one terrain per body is needed")
    unique: dict[int, int] = {}
    terrain_list: list[Terrain] = []
    terrain_of = np.zeros(len(bodies), dtype=np.int32)
    for b, terrain in enumerate(terrains):
        if id(terrain) not in unique:
            unique[id(terrain)] = len(terrain_list)
            terrain_list.append(terrain)
        terrain_of[b] = unique[id(terrain)]
    cache: dict[int, tuple[Geometry, tuple]] = {}  # a batch holds few distinct bodies
    for body in bodies:
        if id(body) not in cache:
            cache[id(body)] = geometry(body), _readings(body)
    geoms = [cache[id(body)][0] for body in bodies]
    positions = [place(g.points, g.corners, t, start_gap) + g.centre
                 for g, t in zip(geoms, terrains)]
    readings = [cache[id(body)][1] for body in bodies]
    normals = [_normals(t) for t in terrain_list]
    return System(
        n_points=np.array([len(g.points) for g in geoms], dtype=np.int32),
        mass=pad([g.mass for g in geoms], (), np.float64, 1.0),
        inertia=pad([g.inertia for g in geoms], (), np.float64, 1.0),
        initial_pos=pad(positions, (2,), np.float64),
        corner_offset=pad([-g.centre for g in geoms], (2,), np.float64),
        n_springs=np.array([len(g.springs) for g in geoms], dtype=np.int32),
        spring_ends=pad([g.springs for g in geoms], (2,), np.int32),
        spring_anchor=pad([g.anchors for g in geoms], (4,), np.float64),
        spring_kind=pad([g.kinds for g in geoms], (), np.int32),
        spring_owner=pad([g.owners for g in geoms], (), np.int32),
        spring_mass=pad([g.spring_mass for g in geoms], (), np.float64, 1.0),
        n_ropes=np.array([len(g.ropes) for g in geoms], dtype=np.int32),
        rope_ends=pad([g.ropes for g in geoms], (2,), np.int32),
        rope_anchor=pad([g.rope_anchors for g in geoms], (4,), np.float64),
        n_voxels=np.array([len(g.corners) for g in geoms], dtype=np.int32),
        voxel_corners=pad([g.corners for g in geoms], (4,), np.int32),
        voxel_x=pad([np.array([x for x, _ in b.shape.voxels]) for b in bodies], (), np.float64),
        n_tips=np.array([len(g.tip_body) for g in geoms], dtype=np.int32),
        tip_body=pad([g.tip_body for g in geoms], (), np.int32),
        tip_offset=pad([g.tip_offset for g in geoms], (2,), np.float64),
        n_blocks=np.array([len(g.block_body) for g in geoms], dtype=np.int32),
        block_body=pad([g.block_body for g in geoms], (), np.int32),
        block_offset=pad([g.block_offset for g in geoms], (2,), np.float64),
        n_readings=np.array([len(c) for c, _ in readings], dtype=np.int32),
        reading_code=pad([np.array(c, dtype=np.int32) for c, _ in readings], (), np.int32),
        reading_voxel=pad([np.array(v, dtype=np.int32) for _, v in readings], (), np.int32),
        terrain_of=terrain_of,
        terrain_n=np.array([len(t.xs) for t in terrain_list], dtype=np.int32),
        terrain_x=pad([t.xs for t in terrain_list], (), np.float64),
        terrain_y=pad([t.ys for t in terrain_list], (), np.float64),
        terrain_nx=pad([nx for nx, _ in normals], (), np.float64),
        terrain_ny=pad([ny for _, ny in normals], (), np.float64),
    )


def _normals(terrain: Terrain) -> tuple[np.ndarray, np.ndarray]:
    dx = np.diff(terrain.xs)
    dy = np.diff(terrain.ys)
    length = np.hypot(dx, dy)
    return -dy / length, dx / length
