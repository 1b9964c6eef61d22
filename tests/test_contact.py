"""Unit tests of the contact and limit kernels on tiny hand-made cases (issue 8, item 6).

The robots, terrains and scratch arrays come from the real builders (compile_system,
robot_view, ground_view, new_scratch), so that the kernels see the types they see in an
episode; the positions and velocities are then set by hand. Expected results are worked out
here from the physics (nearest ground point, Coulomb friction, mass-weighted projections), not
read back from the kernels. Friction, peak depth and the length and area limits are read
from the packed parameters, so that the tests follow the defaults.
"""

from __future__ import annotations

import numpy as np
import pytest

from somite.sim.body import Body
from somite.sim.config import VOXEL_SIDE, pack_params
from somite.sim.physics import (
    CONTACT_TOLERANCE,
    MAX_SIDE_DEPTH,
    enforce_min_lengths,
    extent,
    ground_contact,
    keep_orientation,
    segment_near,
    side_contact,
)
from somite.sim.robot import ground_view, new_scratch, robot_view
from somite.sim.system import compile_system, geometry
from somite.sim.terrain import Terrain

from .conftest import quiet

WALL = 100.0


def terrain(*vertices: tuple[float, float]) -> Terrain:
    """A terrain through ``vertices`` with the usual walls at x = 0 and 10 m past the last."""
    xs = [0.0] + [x for x, _ in vertices] + [vertices[-1][0] + 10.0]
    ys = [vertices[0][1] + WALL] + [y for _, y in vertices] + [vertices[-1][1] + WALL]
    return Terrain("hand-made", np.array(xs), np.array(ys))


FLAT = terrain((10.0, 0.0), (1990.0, 0.0))


def kit(ground_terrain=FLAT, shape="1", **options):
    """Robot, ground, scratch and params of one ``shape`` body on ``ground_terrain``; corners
    are points (``contact_radius`` 0) unless ``options`` say otherwise, so that the geometry
    of the hand-made cases stays exact."""
    params = pack_params(quiet(**{"contact_radius": 0.0, **options}))
    system = compile_system([Body.build(shape, "none")], [ground_terrain])
    robot = robot_view(system, 0, params)
    return robot, ground_view(system, 0), new_scratch(robot), params


def square(x0: float, y0: float, side: float = VOXEL_SIDE) -> np.ndarray:
    """Corners of the 1-voxel body (points ordered by row: SW, SE, NW, NE) at rest."""
    return np.array([[x0, y0], [x0 + side, y0], [x0, y0 + side], [x0 + side, y0 + side]])


def run_ground(robot, ground, scratch, pos, vel, params):
    """ground_contact as substep calls it (leftmost segment and extent of the corners)."""
    lo_x, hi_x, _ = extent(robot.n_points, pos)
    first = segment_near(ground.xs, ground.n, lo_x, 0)
    scratch.contact[:] = True  # stale flags: the kernel must set every one
    ground_contact(robot, ground, scratch, pos, vel, first, hi_x, params)


def run_side(robot, ground, scratch, pos, vel, params):
    lo_x, hi_x, lo_y = extent(robot.n_points, pos)
    first = segment_near(ground.xs, ground.n, lo_x, 0)
    scratch.contact[:] = False
    side_contact(robot, ground, scratch, pos, vel, first, hi_x, lo_y, params)


def coulomb(v_tangent: float, v_normal: float, mu: float) -> float:
    """Tangential speed left after a plastic impact that stops ``v_normal`` (< 0)."""
    return np.sign(v_tangent) * max(0.0, abs(v_tangent) - mu * abs(v_normal))


def signed_area(pos, quad) -> float:
    x, y = pos[quad, 0], pos[quad, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def area_rate(pos, vel, quad) -> float:
    """d/dt of the signed area of corners ``quad`` (counter-clockwise)."""
    x, y = pos[quad, 0], pos[quad, 1]
    gx = 0.5 * (np.roll(y, -1) - np.roll(y, 1))
    gy = 0.5 * (np.roll(x, 1) - np.roll(x, -1))
    return float(np.sum(gx * vel[quad, 0] + gy * vel[quad, 1]))


# ground_contact -------------------------------------------------------------------------------


def test_corner_below_flat_ground_is_put_back_with_coulomb_friction():
    robot, ground, scratch, params = kit()
    mu = params.friction
    pos = np.array([[12.0, -0.05], [14.0, -0.02], [12.5, 0.5], [14.5, 0.5 * CONTACT_TOLERANCE]])
    vel = np.array([[0.3, -1.0], [3.0, -1.0], [0.7, -2.0], [0.4, -0.5]])
    above = (pos[2:].copy(), vel[2:].copy())
    run_ground(robot, ground, scratch, pos, vel, params)
    # Below: straight up onto the surface, normal velocity gone, sliding cut by mu |v_n|.
    np.testing.assert_allclose(pos[:2], [[12.0, 0.0], [14.0, 0.0]], atol=1e-15)
    np.testing.assert_allclose(vel[:2, 1], 0.0, atol=1e-15)
    np.testing.assert_allclose(vel[:2, 0], [coulomb(0.3, -1.0, mu), coulomb(3.0, -1.0, mu)],
                               atol=1e-14)
    assert 0.3 < mu < 3.0  # one corner sticks, the other slides
    # Above (and within the tolerance): untouched.
    np.testing.assert_array_equal(pos[2:], above[0])
    np.testing.assert_array_equal(vel[2:], above[1])
    assert list(scratch.contact) == [True, True, False, True]


def test_corner_below_the_ground_but_leaving_it_keeps_its_velocity():
    robot, ground, scratch, params = kit()
    pos = square(12.0, 0.0)
    pos[:2, 1] = -0.03
    vel = np.array([[1.0, 0.5], [-2.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    before = vel.copy()
    run_ground(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[:2, 1], 0.0, atol=1e-15)
    np.testing.assert_array_equal(vel, before)  # no normal impact, so no friction either
    assert list(scratch.contact) == [True, True, False, False]


def test_corner_below_a_slope_goes_out_along_its_normal():
    """On a 3-4-5 slope, out along the unit normal (-3, 4) / 5; friction along (4, 3) / 5."""
    slope = terrain((10.0, 0.0), (30.0, 0.0), (34.0, 3.0), (1990.0, 3.0))
    robot, ground, scratch, params = kit(slope)
    mu = params.friction
    normal = np.array([-0.6, 0.8])
    tangent = np.array([0.8, 0.6])
    surface = np.array([32.0, 1.5])
    pos = square(31.0, 6.0)
    pos[0] = surface - 0.1 * normal
    vel = np.zeros((4, 2))
    vel[0] = 3.0 * tangent - 1.0 * normal
    run_ground(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[0], surface, atol=1e-14)
    np.testing.assert_allclose(vel[0], coulomb(3.0, -1.0, mu) * tangent, atol=1e-14)
    assert list(scratch.contact) == [True, False, False, False]


def test_corner_near_a_steep_wall_goes_sideways_to_the_nearest_segment():
    """Under the plateau 0.5 m deep but 0.1 m from the wall's face: out through the face."""
    a, b = np.array([20.0, 0.0]), np.array([20.1, 10.0])
    wall = terrain((10.0, 0.0), tuple(a), tuple(b), (40.0, 10.0), (1990.0, 10.0))
    robot, ground, scratch, params = kit(wall)
    mu = params.friction
    s = b - a
    normal = np.array([-s[1], s[0]]) / np.hypot(*s)  # up out of the ground: to the left
    tangent = np.array([normal[1], -normal[0]])
    corner = np.array([20.2, 9.5])
    u = (corner - a) @ s / (s @ s)
    nearest = a + u * s
    pos = square(20.2, 12.0)
    pos[0] = corner
    vel = np.zeros((4, 2))
    vel[0] = [1.0, 3.0]  # into the wall and up along it
    vn, vt = vel[0] @ normal, vel[0] @ tangent
    run_ground(robot, ground, scratch, pos, vel, params)
    assert 0.0 < u < 1.0
    np.testing.assert_allclose(pos[0], nearest, atol=1e-12)
    moved = pos[0] - corner
    assert moved[0] < -0.1 and abs(moved[1]) < 0.01  # sideways, not 0.5 m up
    assert vn < 0.0
    np.testing.assert_allclose(vel[0], coulomb(vt, vn, mu) * tangent, atol=1e-12)
    assert scratch.contact[0]


def test_corner_pushed_onto_a_valley_vertex_stops_going_into_the_ground():
    """The normal at a vertex is the direction of the push, not either segment's normal: the
    result is mirror-symmetric and, without friction, the corner stops going into the ground
    (it kept moving into the right-hand segment before issue 8's fix)."""
    valley = terrain((10.0, 0.0), (20.0, 0.0), (22.0, -1.0), (24.0, 0.0), (1990.0, 0.0))
    robot, ground, scratch, params = kit(valley, friction=0.0)
    pos = square(20.5, 3.0)
    pos[0] = [22.0, -1.05]  # straight below the valley's bottom vertex
    vel = np.zeros((4, 2))
    vel[0] = [0.0, -1.0]
    run_ground(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[0], [22.0, -1.0], atol=1e-12)
    # The push was straight up; a symmetric valley gives no reason to slide either way.
    np.testing.assert_allclose(vel[0], [0.0, 0.0], atol=1e-12)


def test_round_corner_is_kept_a_radius_above_flat_ground():
    radius = 0.3
    robot, ground, scratch, params = kit(contact_radius=radius)
    mu = params.friction
    pos = np.array([[12.0, 0.1], [14.0, radius + 0.5 * CONTACT_TOLERANCE], [12.5, 0.5],
                    [14.5, -0.2]])
    vel = np.array([[3.0, -1.0], [0.4, -0.5], [0.7, -2.0], [0.0, 1.0]])
    untouched = (pos[1:3].copy(), vel[1:3].copy())
    run_ground(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[[0, 3]], [[12.0, radius], [14.5, radius]], atol=1e-15)
    np.testing.assert_allclose(vel[0], [coulomb(3.0, -1.0, mu), 0.0], atol=1e-14)
    np.testing.assert_array_equal(vel[3], [0.0, 1.0])
    np.testing.assert_array_equal(pos[1:3], untouched[0])
    np.testing.assert_array_equal(vel[1:3], untouched[1])
    assert list(scratch.contact) == [True, True, False, True]


def test_round_corner_on_a_crest_is_pushed_straight_away_from_it():
    """A disc right above a crest vertex, closer to it than its radius, rolls on the vertex:
    out along the line from the vertex (straight up), not along either slope's normal."""
    radius = 0.3
    crest = terrain((10.0, 0.0), (20.0, 0.0), (25.0, 1.0), (30.0, 0.0), (1990.0, 0.0))
    robot, ground, scratch, params = kit(crest, contact_radius=radius)
    mu = params.friction
    pos = square(23.5, 4.0)
    pos[0] = [25.0, 1.2]
    vel = np.zeros((4, 2))
    vel[0] = [1.0, -1.0]
    run_ground(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[0], [25.0, 1.0 + radius], atol=1e-14)
    np.testing.assert_allclose(vel[0], [coulomb(1.0, -1.0, mu), 0.0], atol=1e-14)
    assert scratch.contact[0]


# side_contact ---------------------------------------------------------------------------------


def peak_under(x: float, height: float) -> Terrain:
    """Flat ground at 0 with one sharp peak at (x, height)."""
    return terrain((10.0, 0.0), (x - 1.0, 0.0), (x, height), (x + 1.0, 0.0), (1990.0, 0.0))


def at_rest(shape: str, x0: float, y0: float) -> np.ndarray:
    """Corner positions of a body at rest, its SW corner at (x0, y0)."""
    return geometry(Body.build(shape, "none")).points * VOXEL_SIDE + [x0, y0]


@pytest.mark.parametrize("shape, a, lam", [("1", 0, 0.5), ("111", 1, 0.25)])
def test_terrain_peak_in_a_side_is_pushed_out_to_the_tolerated_depth(shape, a, lam):
    """A peak 0.5 m into a bottom side a -> b, at a fraction lam along it (ends of equal mass,
    the peak more than MAX_SIDE_DEPTH from every other side): the side moves away until the
    peak is only max_peak_depth deep at the contact point, each end moving in proportion to
    its share (1 - lam, lam); the contact point's normal velocity stops and its sliding is cut
    by Coulomb friction; nothing else moves."""
    b, y0, depth = a + 1, 1.0, 0.5
    start = at_rest(shape, 11.0, y0)
    tip_x = start[a, 0] + lam * VOXEL_SIDE
    robot, ground, scratch, params = kit(peak_under(tip_x, y0 + depth), shape)
    assert robot.mass[a] == robot.mass[b] and [a, b] in robot.boundary.tolist()
    mu = params.friction
    limit = params.peak_depth
    pos = start.copy()
    vel = np.tile([1.0, -0.5], (robot.n_points, 1))  # sliding right, sinking onto the peak
    run_side(robot, ground, scratch, pos, vel, params)
    wa, wb = 1.0 - lam, lam
    push = (depth - limit) / (wa * wa + wb * wb)
    np.testing.assert_allclose(pos[a] - start[a], [0.0, push * wa], atol=1e-14)
    np.testing.assert_allclose(pos[b] - start[b], [0.0, push * wb], atol=1e-14)
    contact_y = wa * pos[a, 1] + wb * pos[b, 1]
    assert contact_y - (y0 + depth) == pytest.approx(-limit, abs=1e-14)
    point_velocity = wa * vel[a] + wb * vel[b]
    np.testing.assert_allclose(point_velocity, [coulomb(1.0, -0.5, mu), 0.0], atol=1e-14)
    others = np.arange(robot.n_points) > b
    others[:a] = True
    np.testing.assert_array_equal(pos[others], start[others])
    np.testing.assert_array_equal(vel[others], np.tile([1.0, -0.5], (others.sum(), 1)))
    assert np.flatnonzero(scratch.contact).tolist() == [a, b]


def test_peak_inside_a_bottom_side_leaves_the_other_sides_alone():
    limit = pack_params(quiet()).peak_depth
    robot, ground, scratch, params = kit(peak_under(11.75, 1.0 + 0.5 * limit))
    pos = square(11.0, 1.0)
    vel = np.zeros((4, 2))
    run_side(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(pos, square(11.0, 1.0))


def test_side_moving_away_from_the_peak_keeps_its_velocity():
    robot, ground, scratch, params = kit(peak_under(12.5, 1.5))
    pos = square(11.0, 1.0)
    vel = np.tile([0.5, 1.0], (4, 1))
    run_side(robot, ground, scratch, pos, vel, params)
    assert pos[0, 1] > 1.0  # pushed out
    np.testing.assert_array_equal(vel, np.tile([0.5, 1.0], (4, 1)))


def test_peak_within_the_tolerated_depth_is_left_alone():
    limit = pack_params(quiet()).peak_depth
    assert limit > 2 * CONTACT_TOLERANCE
    for depth, touching in ((0.5 * limit, False), (limit - 0.5 * CONTACT_TOLERANCE, True)):
        robot, ground, scratch, params = kit(peak_under(12.5, 1.0 + depth))
        pos = square(11.0, 1.0)
        vel = np.tile([1.0, -0.5], (4, 1))
        run_side(robot, ground, scratch, pos, vel, params)
        np.testing.assert_array_equal(pos, square(11.0, 1.0))
        np.testing.assert_array_equal(vel, np.tile([1.0, -0.5], (4, 1)))
        assert list(scratch.contact) == [touching, touching, False, False]


def test_vertex_deeper_than_max_side_depth_belongs_to_another_side():
    """A peak under the middle of body 111, just over MAX_SIDE_DEPTH into the bottom side: the
    bottom side leaves it alone; the top side pushes it out if it is within MAX_SIDE_DEPTH of
    that one (1.45 m with the default 1.5 m)."""
    start = at_rest("111", 11.0, 1.0)
    depth = MAX_SIDE_DEPTH + 0.05
    robot, ground, scratch, params = kit(peak_under(15.5, 1.0 + depth), "111")
    pos = start.copy()
    vel = np.zeros((robot.n_points, 2))
    run_side(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(pos[:4], start[:4])
    if VOXEL_SIDE - depth < MAX_SIDE_DEPTH:
        assert np.all(pos[5:7, 1] < start[5:7, 1])
        assert np.flatnonzero(scratch.contact).tolist() == [5, 6]
    else:
        assert not scratch.contact.any()


def test_vertex_beyond_the_ends_of_a_side_is_ignored():
    """A square turned 30 degrees about its SW corner (the lowest): the peak is behind the
    bottom side's line, 0.4 m deep, but beyond its SW end, outside the robot."""
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    sw = np.array([20.0, 1.0])
    se = sw + VOXEL_SIDE * np.array([c, s])
    nw = sw + VOXEL_SIDE * np.array([-s, c])
    ne = se + nw - sw
    tip = sw + np.array([-0.3, 0.3])
    bottom = (se - sw) / VOXEL_SIDE
    depth = -(tip - sw) @ np.array([bottom[1], -bottom[0]])
    assert (tip - sw) @ bottom < 0.0 and pack_params(quiet()).peak_depth < depth < MAX_SIDE_DEPTH
    robot, ground, scratch, params = kit(peak_under(*tip))
    pos = np.array([sw, se, nw, ne])
    vel = np.tile([0.0, -1.0], (4, 1))
    run_side(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(pos, [sw, se, nw, ne])
    np.testing.assert_array_equal(vel, np.tile([0.0, -1.0], (4, 1)))
    assert not scratch.contact.any()


def test_side_contact_impulse_has_no_torque_about_the_contact_point():
    """Body 11: the bottom side of the left voxel joins a 0.36 kg corner to a 0.72 kg one."""
    robot, ground, scratch, params = kit(peak_under(12.5, 1.5), shape="11")
    pos = np.array([[11.0, 1.0], [14.0, 1.0], [17.0, 1.0], [11.0, 4.0], [14.0, 4.0],
                    [17.0, 4.0]])
    a, b = 0, 1
    assert robot.mass[b] == 2 * robot.mass[a]
    assert [a, b] in robot.boundary.tolist()
    vel = np.tile([0.0, -1.0], (6, 1))
    before = vel.copy()
    run_side(robot, ground, scratch, pos, vel, params)
    impulse = robot.mass[:, None] * (vel - before)
    contact_point = np.array([12.5, pos[a, 1]])
    arm = pos - contact_point
    torque = np.sum(arm[:, 0] * impulse[:, 1] - arm[:, 1] * impulse[:, 0])
    assert abs(impulse[:, 1].sum()) > 0.1
    assert abs(torque) < 1e-12


# keep_orientation -----------------------------------------------------------------------------


def squeezed(robot, top: float):
    """The 1-voxel body with its top corners lowered to height ``top`` and sheared."""
    pos = square(11.0, 1.0)
    pos[2:, 1] = 1.0 + top
    pos[2:, 0] += 0.4
    return pos


def test_squeezed_voxel_is_restored_to_min_area_without_moving_its_centre():
    robot, _, _, _ = kit()
    quad = robot.corners[0]
    assert np.all(robot.mass == robot.mass[0])
    for deficit in (0.3, 0.05):
        pos = squeezed(robot, (robot.min_area - deficit) / VOXEL_SIDE)
        vel = np.array([[0.2, 0.5], [0.1, 0.5], [0.3, -1.0], [-0.2, -0.8]])  # shrinking
        assert signed_area(pos, quad) == pytest.approx(robot.min_area - deficit, abs=1e-12)
        assert area_rate(pos, vel, quad) < 0.0
        com, momentum = pos.mean(axis=0), vel.sum(axis=0)
        old = pos.copy()
        keep_orientation(robot, pos, vel)
        area = signed_area(pos, quad)
        # Restored to first order: the rest is second order in the deficit.
        assert robot.min_area - 1e-12 <= area <= robot.min_area + 0.05 * deficit
        np.testing.assert_allclose(pos.mean(axis=0), com, atol=1e-14)
        np.testing.assert_allclose(vel.sum(axis=0), momentum, atol=1e-14)
        # The shrinking rate along the correction is removed (measured where it was decided).
        assert area_rate(old, vel, quad) == pytest.approx(0.0, abs=1e-12)


def test_growing_squeezed_voxel_keeps_its_velocity():
    robot, _, _, _ = kit()
    pos = squeezed(robot, 0.5)
    vel = np.array([[0.0, 0.0], [0.0, 0.0], [0.1, 1.0], [0.0, 1.0]])
    assert area_rate(pos, vel, robot.corners[0]) > 0.0
    before = vel.copy()
    keep_orientation(robot, pos, vel)
    assert signed_area(pos, robot.corners[0]) >= robot.min_area - 1e-12
    np.testing.assert_array_equal(vel, before)


def test_voxel_above_min_area_is_untouched():
    robot, _, _, _ = kit()
    pos = squeezed(robot, 1.2 * robot.min_area / VOXEL_SIDE)
    vel = np.array([[0.2, 0.5], [0.1, 0.5], [0.3, -1.0], [-0.2, -0.8]])
    start = (pos.copy(), vel.copy())
    keep_orientation(robot, pos, vel)
    np.testing.assert_array_equal(pos, start[0])
    np.testing.assert_array_equal(vel, start[1])


def test_mirrored_voxel_is_moved_towards_positive_area():
    robot, _, _, _ = kit()
    quad = robot.corners[0]
    pos = square(11.0, 1.0)
    pos[:, 1] = 2.0 - pos[:, 1]  # upside down: same lengths, area -9
    vel = np.zeros((4, 2))
    before = signed_area(pos, quad)
    com = pos.mean(axis=0)
    keep_orientation(robot, pos, vel)
    assert before == pytest.approx(-VOXEL_SIDE**2)
    assert signed_area(pos, quad) > before + 0.5 * VOXEL_SIDE**2
    np.testing.assert_allclose(pos.mean(axis=0), com, atol=1e-14)


def test_orientation_correction_keeps_the_centre_of_mass_for_unequal_masses():
    robot, _, _, _ = kit(shape="11")
    pos = np.array([[11.0, 1.0], [14.0, 1.0], [17.0, 1.0], [11.0, 1.6], [14.3, 1.5],
                    [17.0, 4.0]])
    vel = np.tile([0.0, -1.0], (6, 1))
    vel[:3] = 0.0
    mass = robot.mass[:, None]
    com, momentum = (mass * pos).sum(axis=0), (mass * vel).sum(axis=0)
    keep_orientation(robot, pos, vel)
    assert signed_area(pos, robot.corners[0]) >= robot.min_area - 1e-12
    np.testing.assert_allclose((mass * pos).sum(axis=0), com, atol=1e-13)
    np.testing.assert_allclose((mass * vel).sum(axis=0), momentum, atol=1e-13)


# enforce_min_lengths --------------------------------------------------------------------------


def limit_lengths(robot, pos, vel):
    enforce_min_lengths(robot.n_springs, robot.ends, robot.min_length, robot.inv_mass, pos, vel)


def test_short_springs_are_pushed_to_their_limit_conserving_momentum():
    """Body 11 squeezed sideways: the left voxel's bottom and top sides (0.36 kg and 0.72 kg
    ends) are 2 m long. They come back to exactly their limit, the lighter end moving twice
    as far, and the ends stop closing; momentum and centre of mass are unchanged."""
    robot, _, _, _ = kit(shape="11")
    pos = np.array([[12.0, 1.0], [14.0, 1.0], [17.0, 1.0], [12.0, 4.0], [14.0, 4.0],
                    [17.0, 4.0]])
    vel = np.array([[1.0, 0.0], [-0.5, 0.2], [0.0, 0.0], [0.3, 0.0], [0.0, 0.0], [0.0, 0.0]])
    mass = robot.mass[:, None]
    com, momentum = (mass * pos).sum(axis=0), (mass * vel).sum(axis=0)
    old = pos.copy()
    short = [s for s, (a, b) in enumerate(robot.ends)
             if np.hypot(*(pos[b] - pos[a])) < robot.min_length[s]]
    assert sorted(sorted(pair) for pair in robot.ends[short].tolist()) == [[0, 1], [3, 4]]
    limit_lengths(robot, pos, vel)
    for s in short:
        a, b = sorted(robot.ends[s])  # a on the left, the lighter end
        assert np.hypot(*(pos[b] - pos[a])) == pytest.approx(robot.min_length[s], abs=1e-12)
        shift_a, shift_b = pos[a] - old[a], pos[b] - old[b]
        np.testing.assert_allclose(robot.mass[a] * shift_a, -robot.mass[b] * shift_b,
                                   atol=1e-14)
        assert shift_a[0] < 0.0 < shift_b[0]
        assert (vel[b, 0] - vel[a, 0]) == pytest.approx(0.0, abs=1e-14)  # no longer closing
    np.testing.assert_allclose(vel[:, 1], [0.0, 0.2, 0.0, 0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose((mass * pos).sum(axis=0), com, atol=1e-13)
    np.testing.assert_allclose((mass * vel).sum(axis=0), momentum, atol=1e-13)
    for s, (a, b) in enumerate(robot.ends):
        assert np.hypot(*(pos[b] - pos[a])) >= robot.min_length[s] - 1e-12


def test_springs_above_their_limit_are_untouched():
    robot, _, _, _ = kit(shape="11")
    pos = np.array([[11.0, 1.0], [14.0, 1.0], [17.0, 1.0], [11.0, 4.0], [14.0, 4.0],
                    [17.0, 4.0]])
    pos[:, 0] *= 1.0 - 0.9 * (1.0 - robot.min_length[-1] / VOXEL_SIDE)
    vel = np.ones((6, 2))
    start = (pos.copy(), vel.copy())
    limit_lengths(robot, pos, vel)
    np.testing.assert_array_equal(pos, start[0])
    np.testing.assert_array_equal(vel, start[1])
