"""Static arrays of a batch of robots, padded to the largest robot of the batch.

Axis glossary: B robots, P points (voxel corners), S springs, V voxels, R sensor readings,
Q boundary sides, T terrains, K terrain vertices. Padding entries are never read: every kernel
loop runs to the robot's own count (``n_points[b]`` and so on), which is why a robot's outcome
does not depend on the other robots of its batch.

Geometry (decisions.md, "The simulator is ours"): a voxel is 4 corner point masses, shared with
its neighbours, and 6 springs (4 sides, 2 diagonals). A side shared by two voxels carries one
spring of each; as two linear springs in parallel equal one spring of double stiffness at their
mean rest length, it is stored once with both owners.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .body import SENSOR_WIDTH, Body
from .config import CORNER_MASS, VOXEL_SIDE
from .terrain import Terrain

# Reading codes: which quantity one scalar reading measures.
R_AREA, R_TOUCH, R_VX, R_VY, R_LIDAR0 = 0, 1, 2, 3, 4
_READING_CODES = {"area": (R_AREA,), "touch": (R_TOUCH,), "velocity": (R_VX, R_VY)}
_READING_CODES["lidar"] = tuple(R_LIDAR0 + k for k in range(SENSOR_WIDTH["lidar"]))

PLACEMENT_GAP = 1.0
"""Metres between the ground and the robot's lowest voxel at the start."""


class System(NamedTuple):
    """The static description of a batch (shapes after each field, units in brackets)."""

    n_points: np.ndarray  # (B,) int32
    mass: np.ndarray  # (B, P) [kg]
    initial_pos: np.ndarray  # (B, P, 2) [m], placed on the robot's terrain
    n_springs: np.ndarray  # (B,) int32
    spring_ends: np.ndarray  # (B, S, 2) int32 point indices
    spring_owners: np.ndarray  # (B, S, 2) int32 voxel indices, -1 when only one owner
    spring_rest: np.ndarray  # (B, S) [m] rest length at zero actuation
    spring_diagonal: np.ndarray  # (B, S) bool: a voxel's diagonal (else a side)
    n_voxels: np.ndarray  # (B,) int32
    voxel_corners: np.ndarray  # (B, V, 4) int32 points SW, SE, NE, NW (counter-clockwise)
    voxel_x: np.ndarray  # (B, V) grid column of each voxel
    n_boundary: np.ndarray  # (B,) int32
    boundary: np.ndarray  # (B, Q, 2) int32 outer sides, robot on the left of a -> b
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
    """One body's points, springs, corners and outer sides at rest, before placement."""

    points: np.ndarray  # (P, 2) lattice coordinates in voxel units
    mass: np.ndarray  # (P,)
    springs: np.ndarray  # (S, 2)
    owners: np.ndarray  # (S, 2)
    rest: np.ndarray  # (S,)
    diagonal: np.ndarray  # (S,) bool
    corners: np.ndarray  # (V, 4)
    boundary: np.ndarray  # (Q, 2)


def geometry(body: Body) -> Geometry:
    """Points, springs and outer sides of a body, in the body's voxel order."""
    voxels = body.shape.voxels
    lattice: dict[tuple[int, int], int] = {}
    for x, y in voxels:
        for corner in ((x, y), (x + 1, y), (x + 1, y + 1), (x, y + 1)):
            lattice.setdefault(corner, 0)
    ordered = sorted(lattice, key=lambda c: (c[1], c[0]))
    index = {c: i for i, c in enumerate(ordered)}
    mass = np.zeros(len(ordered))
    corners = np.zeros((len(voxels), 4), dtype=np.int32)
    sides: dict[frozenset, list] = {}
    springs, owners, rest = [], [], []
    for v, (x, y) in enumerate(voxels):
        quad = [index[(x, y)], index[(x + 1, y)], index[(x + 1, y + 1)], index[(x, y + 1)]]
        corners[v] = quad
        mass[quad] += CORNER_MASS
        for k in range(4):
            a, b = quad[k], quad[(k + 1) % 4]
            sides.setdefault(frozenset((a, b)), []).append((v, a, b))
        for a, b in ((quad[0], quad[2]), (quad[1], quad[3])):
            springs.append((a, b))
            owners.append((v, -1))
            rest.append(VOXEL_SIDE * math.sqrt(2))
    boundary = []
    for uses in sides.values():
        v, a, b = uses[0]
        springs.append((a, b))
        owners.append((v, uses[1][0] if len(uses) > 1 else -1))
        rest.append(VOXEL_SIDE)
        if len(uses) == 1:
            boundary.append((a, b))
    return Geometry(
        points=np.asarray(ordered, dtype=np.float64),
        mass=mass,
        springs=np.asarray(springs, dtype=np.int32),
        owners=np.asarray(owners, dtype=np.int32),
        rest=np.asarray(rest, dtype=np.float64),
        diagonal=np.arange(len(springs)) < 2 * len(voxels),
        corners=corners,
        boundary=np.asarray(boundary, dtype=np.int32).reshape(-1, 2),
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
    positions = [place(g.points, g.corners, t, start_gap) for g, t in zip(geoms, terrains)]
    readings = [cache[id(body)][1] for body in bodies]
    normals = [_normals(t) for t in terrain_list]
    return System(
        n_points=np.array([len(g.points) for g in geoms], dtype=np.int32),
        mass=pad([g.mass for g in geoms], (), np.float64, 1.0),
        initial_pos=pad(positions, (2,), np.float64),
        n_springs=np.array([len(g.springs) for g in geoms], dtype=np.int32),
        spring_ends=pad([g.springs for g in geoms], (2,), np.int32),
        spring_owners=pad([g.owners for g in geoms], (2,), np.int32, -1),
        spring_rest=pad([g.rest for g in geoms], (), np.float64, 1.0),
        spring_diagonal=pad([g.diagonal for g in geoms], (), np.bool_),
        n_voxels=np.array([len(g.corners) for g in geoms], dtype=np.int32),
        voxel_corners=pad([g.corners for g in geoms], (4,), np.int32),
        voxel_x=pad([np.array([x for x, _ in b.shape.voxels]) for b in bodies], (), np.float64),
        n_boundary=np.array([len(g.boundary) for g in geoms], dtype=np.int32),
        boundary=pad([g.boundary for g in geoms], (2,), np.int32),
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
