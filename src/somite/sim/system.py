"""Static arrays of a batch of robots, padded to the largest robot of the batch.

Axis glossary: B robots, P bodies (four per voxel: the blocks at its corners), S springs,
Y rope limits, W welds, V voxels, R sensor readings, T terrains, K terrain vertices. Padding
entries are never read: every kernel loop runs to the robot's own count (``n_points[b]`` and
so on), which is why a robot's outcome does not depend on the other robots of its batch.

Geometry, as in the original (docs/original-system.md sections 1.2 and 1.4): each voxel corner holds
a rigid square block of its own, inside the voxel. A voxel joins its four blocks with 18 soft
springs anchored on the blocks' corners and centres, and 4 rope limits keep its adjacent blocks from
overlapping; neighbouring voxels are joined by two rigid welds per shared side, each anchored at its
first block's centre.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .._arrays import pad
from .body import Body
from .config import BLOCK_INERTIA, BLOCK_SIDE, CORNER_MASS, VOXEL_SIDE
from .sensor_kinds import reading_code
from .terrain import Terrain

SPRING_SIDE, SPRING_CROSS, SPRING_CENTRAL = 0, 1, 2
"""The original's spring groups (docs/original-system.md section 1.2): each has its own range."""

PLACEMENT_GAP = 1.0
"""Metres between the ground and the robot's lowest voxel at the start."""


class System(NamedTuple):
    """The static description of a batch (shapes after each field, units in brackets).

    Bodies are the voxels' corner blocks, four per voxel, so a body index is also the index of
    the voxel corner that it carries. Offsets are from a body's centre of mass in its own frame
    (at rest the frame is the world's)."""

    n_points: np.ndarray  # (B,) int32 bodies (4 a voxel)
    mass: np.ndarray  # (B, P) [kg]
    inertia: np.ndarray  # (B, P) [kg m^2] about the body's centre of mass
    initial_pos: np.ndarray  # (B, P, 2) [m] centres of mass, placed on the robot's terrain
    corner_offset: np.ndarray  # (B, P, 2) [m] the voxel corner that the block carries
    n_springs: np.ndarray  # (B,) int32
    spring_ends: np.ndarray  # (B, S, 2) int32 body indices
    spring_anchor: np.ndarray  # (B, S, 4) [m] offsets of the two anchors (x_a, y_a, x_b, y_b)
    spring_kind: np.ndarray  # (B, S) int32 SPRING_SIDE / SPRING_CROSS / SPRING_CENTRAL
    spring_owner: np.ndarray  # (B, S) int32 voxel whose actuation sets the rest length
    n_ropes: np.ndarray  # (B,) int32
    rope_ends: np.ndarray  # (B, Y, 2) int32 body indices (anchored at the block centres)
    n_welds: np.ndarray  # (B,) int32
    weld_ends: np.ndarray  # (B, W, 2) int32 body indices
    weld_anchor: np.ndarray  # (B, W, 2) [m] the first body's centre, offset on the second
    n_pairs: np.ndarray  # (B,) int32
    pair_ends: np.ndarray  # (B, C, 2) int32 blocks that share no joint: they may collide
    n_voxels: np.ndarray  # (B,) int32
    voxel_corners: np.ndarray  # (B, V, 4) int32 bodies SW, SE, NE, NW (counter-clockwise)
    voxel_x: np.ndarray  # (B, V) grid column of each voxel
    n_readings: np.ndarray  # (B,) int32
    reading_code: np.ndarray  # (B, R) int32 sensor_kinds.reading_code: kind and component
    reading_voxel: np.ndarray  # (B, R) int32
    terrain_of: np.ndarray  # (B,) int32 index into the terrain arrays
    terrain_n: np.ndarray  # (T,) int32 vertices of each terrain
    terrain_x: np.ndarray  # (T, K) [m] strictly increasing
    terrain_y: np.ndarray  # (T, K) [m]
    terrain_nx: np.ndarray  # (T, K) unit normal of segment [k, k+1], pointing up out of the
    terrain_ny: np.ndarray  # (T, K) ground (left of the segment's direction)


class Geometry(NamedTuple):
    """One body's blocks, springs, ropes and welds at rest, before placement. Offsets in
    metres from each block's centre of mass."""

    points: np.ndarray  # (P, 2) lattice coordinates of each block's voxel corner
    centre: np.ndarray  # (P, 2) [m] the block's centre relative to that corner
    springs: np.ndarray  # (S, 2)
    anchors: np.ndarray  # (S, 4)
    kinds: np.ndarray  # (S,)
    owners: np.ndarray  # (S,)
    ropes: np.ndarray  # (Y, 2)
    welds: np.ndarray  # (W, 2)
    weld_anchors: np.ndarray  # (W, 2)
    pairs: np.ndarray  # (C, 2)
    corners: np.ndarray  # (V, 4)


# Where each corner's block lies inside its voxel (corners SW, SE, NE, NW), and the voxel's
# sides as pairs of corners.
_INTO_VOXEL = ((1, 1), (-1, 1), (-1, -1), (1, -1))
_SIDES = ((0, 1), (1, 2), (2, 3), (3, 0))
SW, SE, NE, NW = range(4)
_WELDS = (((-1, 0), ((NW, NE), (SW, SE))), ((0, -1), ((SW, NW), (SE, NE))))
"""The original's welds: with the left neighbour (this NW to its NE, this SW to its SE) and
with the one below (this SW to its NW, this SE to its NE); the first block is this voxel's."""


def geometry(body: Body) -> Geometry:
    """Blocks, springs, ropes, welds and collision pairs of a body, in the body's voxel order
    (voxel v owns blocks 4v .. 4v + 3, at its corners SW, SE, NE, NW).

    Each voxel joins its four blocks with 18 springs (per side: the inner and the outer facing
    corners, and the two crossings of them; and the two diagonals between block centres) and keeps
    adjacent blocks apart with 4 rope limits between their centres
    (docs/original-system.md section 1.2); neighbouring voxels are welded (section 1.4). Blocks
    that share no joint collide with each other, as in the original, where joined bodies never
    do.
    """
    voxels = body.shape.voxels
    index = {c: v for v, c in enumerate(voxels)}
    half = BLOCK_SIDE / 2
    n = 4 * len(voxels)
    points = np.zeros((n, 2))
    centre = np.zeros((n, 2))
    corners = np.arange(n, dtype=np.int32).reshape(-1, 4)
    for v, (x, y) in enumerate(voxels):
        for k, (c, (ix, iy)) in enumerate(zip(((x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)),
                                              _INTO_VOXEL)):
            points[4 * v + k] = c
            centre[4 * v + k] = (ix * half, iy * half)
    world = points * VOXEL_SIDE + centre  # block centres at rest

    springs, anchors, kinds, owners, ropes = [], [], [], [], []
    for v in range(len(voxels)):
        quad = corners[v]
        middle = world[quad].mean(axis=0)
        for ka, kb in _SIDES:
            a, b = int(quad[ka]), int(quad[kb])
            ca, cb = world[a], world[b]
            u = (cb - ca) / np.linalg.norm(cb - ca)
            w = middle - (ca + cb) / 2
            w = w / np.linalg.norm(w)  # into the voxel
            a_out, a_in = ca + half * u - half * w, ca + half * u + half * w
            b_out, b_in = cb - half * u - half * w, cb - half * u + half * w
            for pa, pb, kind in ((a_in, b_in, SPRING_SIDE), (a_out, b_out, SPRING_SIDE),
                                 (a_out, b_in, SPRING_CROSS), (a_in, b_out, SPRING_CROSS)):
                springs.append((a, b))
                anchors.append((*(pa - ca), *(pb - cb)))
                kinds.append(kind)
                owners.append(v)
            ropes.append((a, b))
        for ka, kb in ((NW, SE), (NE, SW)):
            springs.append((int(quad[ka]), int(quad[kb])))
            anchors.append((0.0, 0.0, 0.0, 0.0))
            kinds.append(SPRING_CENTRAL)
            owners.append(v)
    welds, weld_anchors = [], []
    for v, (x, y) in enumerate(voxels):
        for (dx, dy), pairs in _WELDS:
            other = index.get((x + dx, y + dy))
            if other is None:
                continue
            for mine, theirs in pairs:
                a, b = 4 * v + mine, 4 * other + theirs
                welds.append((a, b))
                weld_anchors.append(tuple(world[a] - world[b]))
    joined = {frozenset(e) for e in springs} | {frozenset(e) for e in ropes}
    joined |= {frozenset(e) for e in welds}
    reach = BLOCK_SIDE * math.sqrt(2.0) + 1e-9
    pairs = [(a, b) for a in range(n) for b in range(a + 1, n)
             if frozenset((a, b)) not in joined
             and np.linalg.norm(world[a] - world[b]) <= reach]
    return Geometry(
        points=points,
        centre=centre,
        springs=np.asarray(springs, dtype=np.int32),
        anchors=np.asarray(anchors, dtype=np.float64),
        kinds=np.asarray(kinds, dtype=np.int32),
        owners=np.asarray(owners, dtype=np.int32),
        ropes=np.asarray(ropes, dtype=np.int32),
        welds=np.asarray(welds, dtype=np.int32).reshape(-1, 2),
        weld_anchors=np.asarray(weld_anchors, dtype=np.float64).reshape(-1, 2),
        pairs=np.asarray(pairs, dtype=np.int32).reshape(-1, 2),
        corners=corners,
    )


def place(points: np.ndarray, corners: np.ndarray, terrain: Terrain, gap: float) -> np.ndarray:
    """Rest positions [m] on ``terrain``: left edge ``gap`` right of the left wall's foot
    (1 m in the paper), lowest voxel PLACEMENT_GAP above the ground under its centre
    (docs/original-system.md section 1.6)."""
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
        codes.append(reading_code(reading.kind, reading.component))
        voxels.append(reading.voxel)
    return codes, voxels


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
        mass=pad([np.full(len(g.points), CORNER_MASS) for g in geoms], (), np.float64, 1.0),
        inertia=pad([np.full(len(g.points), BLOCK_INERTIA) for g in geoms], (), np.float64, 1.0),
        initial_pos=pad(positions, (2,), np.float64),
        corner_offset=pad([-g.centre for g in geoms], (2,), np.float64),
        n_springs=np.array([len(g.springs) for g in geoms], dtype=np.int32),
        spring_ends=pad([g.springs for g in geoms], (2,), np.int32),
        spring_anchor=pad([g.anchors for g in geoms], (4,), np.float64),
        spring_kind=pad([g.kinds for g in geoms], (), np.int32),
        spring_owner=pad([g.owners for g in geoms], (), np.int32),
        n_ropes=np.array([len(g.ropes) for g in geoms], dtype=np.int32),
        rope_ends=pad([g.ropes for g in geoms], (2,), np.int32),
        n_welds=np.array([len(g.welds) for g in geoms], dtype=np.int32),
        weld_ends=pad([g.welds for g in geoms], (2,), np.int32),
        weld_anchor=pad([g.weld_anchors for g in geoms], (2,), np.float64),
        n_pairs=np.array([len(g.pairs) for g in geoms], dtype=np.int32),
        pair_ends=pad([g.pairs for g in geoms], (2,), np.int32),
        n_voxels=np.array([len(g.corners) for g in geoms], dtype=np.int32),
        voxel_corners=pad([g.corners for g in geoms], (4,), np.int32),
        voxel_x=pad([np.array([x for x, _ in b.shape.voxels]) for b in bodies], (), np.float64),
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
