"""Unit tests of the body model and the sequential-impulse kernels on small hand-made cases.

The robots, terrains and scratch arrays come from the real builders (compile_system,
robot_view, ground_view, robot_body), so that the kernels see the types they see in an
episode; positions and velocities are then set by hand. Expected results are worked out here
from the geometry and the physics (the original's spring ranges, counts of joints, where two
squares touch, momentum balances), not read back from the kernels.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.brain.controllers import Sine, Table, Zero
from somite.sim.body import Body
from somite.sim.config import BLOCK_INERTIA, BLOCK_SIDE, CORNER_MASS, VOXEL_SIDE, pack_params
from somite.sim.physics import (
    HALF_BLOCK,
    LINEAR_SLOP,
    deepest_axis,
    manifold,
    set_rest_lengths,
    spring_length,
)
from somite.sim.robot import robot_body, robot_view
from somite.sim.system import (
    SPRING_CENTRAL,
    SPRING_CROSS,
    SPRING_SIDE,
    compile_system,
    geometry,
)
from somite.sim.terrain import Terrain, parse_terrain
from somite.tasks.locomotion import simulate_batch

from .conftest import quiet

FLAT = Terrain("flat", np.array([0.0, 10.0, 1990.0, 2000.0]), np.array([100.0, 0.0, 0.0, 100.0]))


def kit(ground_terrain=FLAT, shape="1", **options):
    """Robot, body state and params of one ``shape`` body on ``ground_terrain``."""
    params = pack_params(quiet(**options))
    system = compile_system([Body.build(shape, "none")], [ground_terrain])
    robot = robot_view(system, 0, params)
    return robot, robot_body(robot), params


def square(cx, cy, angle=0.0, half=HALF_BLOCK) -> np.ndarray:
    """A block as the kernels see it (4, 4): vertices counter-clockwise from the lower left
    (in its frame), each with the outward normal of the edge to the next."""
    c, s = math.cos(angle), math.sin(angle)
    local = [(-half, -half), (half, -half), (half, half), (-half, half)]
    normals = [(0, -1), (1, 0), (0, 1), (-1, 0)]
    poly = np.zeros((4, 4))
    for j, ((lx, ly), (nx, ny)) in enumerate(zip(local, normals)):
        poly[j] = (cx + c * lx - s * ly, cy + s * lx + c * ly, c * nx - s * ny, s * nx + c * ny)
    return poly


def ground_quad(x0, y0, x1, y1, depth=50.0) -> np.ndarray:
    """The ground under the segment (x0, y0)-(x1, y1), counter-clockwise from its left end."""
    base = min(y0, y1) - depth
    pts = [(x0, y0), (x0, base), (x1, base), (x1, y1)]
    poly = np.zeros((4, 4))
    for j in range(4):
        (ax, ay), (bx, by) = pts[j], pts[(j + 1) % 4]
        length = math.hypot(bx - ax, by - ay)
        poly[j] = (ax, ay, (by - ay) / length, -(bx - ax) / length)
    return poly


# the spring ranges ---------------------------------------------------------------------------

ORIGINAL_RANGES = {  # docs/original-system.md section 1.2: [min, rest, max] lengths per group
    SPRING_SIDE: (0.24102, 0.6, 0.92039),
    SPRING_CROSS: (1.22397, 1.34164, 1.51232),
    SPRING_CENTRAL: (2.03791, 2.54558, 2.99869),
}


@pytest.mark.parametrize("kind", sorted(ORIGINAL_RANGES))
def test_spring_lengths_match_the_original_ranges(kind):
    params = pack_params(quiet(area_delta=0.225))
    lengths = [spring_length(kind, params.contract), spring_length(kind, 1.0),
               spring_length(kind, params.expand)]
    np.testing.assert_allclose(lengths, ORIGINAL_RANGES[kind], atol=6e-6)


def test_rest_lengths_follow_each_voxels_actuation_within_the_ranges():
    """Body 11 (36 springs): voxel 0 at actuation a, voxel 1 at -a. Contraction (+1) gives
    the group's minimum, expansion (-1) its maximum, linearly in between, and actuations
    beyond +-1 are clipped."""
    robot, scratch, params = kit(shape="11", area_delta=0.225)
    lo = {k: r[0] for k, r in ORIGINAL_RANGES.items()}
    mid = {k: r[1] for k, r in ORIGINAL_RANGES.items()}
    hi = {k: r[2] for k, r in ORIGINAL_RANGES.items()}
    for a in (0.0, 1.0, -1.0, 0.5, -0.25, 3.0, -7.0):
        actuation = np.array([a, -a])
        set_rest_lengths(robot.n_springs, robot.kind, robot.owner, actuation, params.contract,
                         params.expand, scratch.rest)
        for s in range(robot.n_springs):
            k = int(robot.kind[s])
            f = min(1.0, max(-1.0, actuation[robot.owner[s]]))
            expected = mid[k] - (mid[k] - lo[k]) * f if f >= 0 else mid[k] + (hi[k] - mid[k]) * -f
            assert scratch.rest[s] == pytest.approx(expected, abs=1e-5), (a, s)
    assert sorted(set(robot.owner.tolist())) == [0, 1]


# geometry -----------------------------------------------------------------------------------

SHAPES = ["1", "11", "111/101", "biped", "worm"]


def adjacencies(shape: str) -> int:
    voxels = set(Body.build(shape, "none").shape.voxels)
    return sum((x + 1, y) in voxels for x, y in voxels) + sum((x, y + 1) in voxels
                                                              for x, y in voxels)


@pytest.mark.parametrize("shape", SHAPES)
def test_each_voxel_has_its_own_four_blocks_18_springs_4_ropes_and_two_welds_per_side(shape):
    body = Body.build(shape, "none")
    g = geometry(body)
    voxels = body.shape.n_voxels
    assert len(g.points) == 4 * voxels
    assert len(g.springs) == 18 * voxels and len(g.ropes) == 4 * voxels
    assert len(g.welds) == 2 * adjacencies(shape)
    # every joint of a voxel joins that voxel's own blocks; every weld joins two voxels
    for (a, b), v in zip(g.springs, g.owners):
        assert a // 4 == b // 4 == v
    for a, b in g.welds:
        assert a // 4 != b // 4


def test_the_papers_bodies_have_the_originals_weld_counts():
    # docs/original-system.md section 1.4: the biped 12 adjacencies (24 welds), the worm 16 (32)
    assert len(geometry(Body.build("biped", "none")).welds) == 24
    assert len(geometry(Body.build("worm", "none")).welds) == 32


@pytest.mark.parametrize("shape", SHAPES)
def test_spring_anchors_at_rest_have_the_rest_lengths_and_ropes_are_slack(shape):
    g = geometry(Body.build(shape, "none"))
    centres = g.points * VOXEL_SIDE + g.centre
    for (a, b), anchor, kind in zip(g.springs, g.anchors, g.kinds):
        length = np.linalg.norm(centres[b] + anchor[2:] - centres[a] - anchor[:2])
        assert length == pytest.approx(ORIGINAL_RANGES[int(kind)][1], abs=1e-5)
    for a, b in g.ropes:
        assert np.linalg.norm(centres[b] - centres[a]) == pytest.approx(VOXEL_SIDE - BLOCK_SIDE)


@pytest.mark.parametrize("shape, pairs", [("1", 0), ("11", 0), ("worm", 10), ("biped", 8)])
def test_blocks_that_share_no_joint_and_touch_at_rest_may_collide(shape, pairs):
    """At a lattice point where four voxels meet, the two diagonal pairs of blocks are not
    joined (the welds join the side neighbours): the worm has 5 such points, the biped 3 and
    two where three voxels meet (one diagonal pair each)."""
    g = geometry(Body.build(shape, "none"))
    assert len(g.pairs) == pairs
    joined = {frozenset(map(int, e)) for e in (*g.springs, *g.ropes, *g.welds)}
    centres = g.points * VOXEL_SIDE + g.centre
    for a, b in g.pairs:
        assert frozenset((int(a), int(b))) not in joined
        assert np.linalg.norm(centres[a] - centres[b]) == pytest.approx(BLOCK_SIDE * math.sqrt(2))


def test_blocks_weigh_036_kg_and_carry_their_voxels_corners():
    system = compile_system([Body.build("11", "none")], [FLAT])
    assert np.all(system.mass[0] == CORNER_MASS)
    assert np.all(system.inertia[0] == pytest.approx(BLOCK_INERTIA))
    corners = system.initial_pos[0] + system.corner_offset[0]
    quads = corners[system.voxel_corners[0]]  # (V, 4, 2) SW, SE, NE, NW
    np.testing.assert_allclose(quads[:, 1] - quads[:, 0], [[VOXEL_SIDE, 0.0]] * 2)
    np.testing.assert_allclose(quads[:, 3] - quads[:, 0], [[0.0, VOXEL_SIDE]] * 2)
    np.testing.assert_allclose(quads[1, 0] - quads[0, 0], [VOXEL_SIDE, 0.0])


# contact geometry ---------------------------------------------------------------------------


def test_a_block_sunk_flat_into_the_ground_touches_it_at_its_two_bottom_corners():
    ground = ground_quad(-10, 0, 10, 0)
    block = square(0.3, HALF_BLOCK - 0.02)
    overlap, nx, ny = deepest_axis(ground, block)
    assert overlap == pytest.approx(0.02) and (nx, ny) == pytest.approx((0.0, 1.0))
    clipped = np.zeros((2, 4))
    points, flipped, _, _, tx, ty = manifold(ground, block, nx, ny, clipped)
    assert points == 2 and not flipped and (tx, ty) == pytest.approx((0.0, 1.0))
    assert sorted(clipped[:, 0]) == pytest.approx([0.3 - HALF_BLOCK, 0.3 + HALF_BLOCK])
    np.testing.assert_allclose(clipped[:, 1], -0.02)
    np.testing.assert_allclose(clipped[:, 3], 0.02)


def test_a_block_on_its_corner_touches_at_that_corner_only():
    ground = ground_quad(-10, 0, 10, 0)
    reach = HALF_BLOCK * math.sqrt(2)
    block = square(1.0, reach - 0.01, math.pi / 4)
    overlap, nx, ny = deepest_axis(ground, block)
    clipped = np.zeros((2, 4))
    points, *_ = manifold(ground, block, nx, ny, clipped)
    assert points == 1
    assert clipped[0, :2] == pytest.approx((1.0, -0.01), abs=1e-12)
    assert clipped[0, 3] == pytest.approx(0.01)


def test_a_block_resting_on_a_crest_touches_at_the_crest_with_its_face_as_reference():
    """A sharp crest under the middle of a block's bottom face: the block's face is the
    reference, and the contact is the ground's vertex, pushing the block straight up."""
    ground = ground_quad(-2, -2, 0, 0)  # the left flank of a crest at (0, 0)
    block = square(0.0, HALF_BLOCK - 0.01)
    overlap, nx, ny = deepest_axis(ground, block)
    assert overlap > 0
    clipped = np.zeros((2, 4))
    points, flipped, _, _, tx, ty = manifold(ground, block, nx, ny, clipped)
    assert flipped and points >= 1
    assert (tx, ty) == pytest.approx((0.0, 1.0), abs=1e-12)
    assert clipped[0, :2] == pytest.approx((0.0, 0.0), abs=1e-12)
    assert clipped[0, 3] == pytest.approx(0.01)


def test_separate_polygons_do_not_overlap():
    assert deepest_axis(ground_quad(-10, 0, 10, 0), square(0.0, HALF_BLOCK + 0.001))[0] == 0.0
    assert deepest_axis(square(0, 0), square(BLOCK_SIDE + 1e-6, 0))[0] == 0.0


# the solver ---------------------------------------------------------------------------------


def test_a_voxel_dropped_on_flat_ground_comes_to_rest_on_its_bottom_blocks():
    body = Body.build("1", "none")
    _, trace = simulate_batch([body], [FLAT], [Zero()], quiet(duration=4.0), record=True)
    corners = trace.pos[0]  # (steps, 4, 2): SW, SE, NE, NW
    np.testing.assert_allclose(corners[-60:], corners[-1:].repeat(60, axis=0), atol=1e-3)
    bottom = corners[-1, :2, 1]
    assert np.all(bottom <= 0) and np.all(bottom > -3 * LINEAR_SLOP)
    assert trace.contact[0, -1].tolist() == [True, True, False, False]
    # it fell straight: the solver's order turns the blocks a little, no more
    np.testing.assert_allclose(corners[-1, :, 0], corners[0, :, 0], atol=3e-3)


def test_springs_ropes_and_welds_move_no_centre_of_mass_in_the_air():
    """No gravity to speak of, no damping, the ground out of reach: whatever the voxels do to
    each other, a robot that starts at rest keeps its centre of mass where it was."""
    body = Body.build("11", "none")
    config = quiet(duration=2.0, gravity=1e-12, drag=0.0)
    _, trace = simulate_batch([body], [FLAT], [Sine(2.0, 1.0, 1.0)], config, record=True)
    assert not trace.contact[0].any()
    assert np.ptp(trace.pos[0, :, :, 0], axis=0).max() > 0.1  # the voxels did move
    np.testing.assert_allclose(trace.com[0], trace.com[0, :1].repeat(len(trace.com[0]), axis=0),
                               atol=1e-9)


def test_a_contracted_bottom_voxel_lifts_its_blocks_and_reads_no_touch():
    """Touch is per voxel, on its own blocks (docs/original-system.md section 2.1): the worm's
    contracted end voxel pulls its free block off the ground and hangs on its welds, so it
    reads 0, while a resting voxel of the same row reads 1 (one body per lattice point would
    have read 1 for both: the contracted voxel's welded block still rests on the ground)."""
    body = Body.build("worm", {(x, 0): ["touch"] for x in range(6)})
    voxels = body.shape.voxels
    contracted = voxels.index((0, 0))
    other = voxels.index((3, 0))
    pose = np.zeros((1, body.shape.n_voxels))
    pose[0, contracted] = 1.0
    _, trace = simulate_batch([body], [parse_terrain("flat")], [Table(pose)], quiet(duration=4.0),
                        record=True)
    readings = trace.readings[0, -1]
    order = [r.voxel for r in body.readings]
    assert readings[order.index(contracted)] == 0.0
    assert readings[order.index(other)] == 1.0
