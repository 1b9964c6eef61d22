"""Unit tests of the constraint and contact kernels of the rigid-block model on tiny hand-made
cases (issue 8, item 6).

The robots, terrains and scratch arrays come from the real builders (compile_system,
robot_view, ground_view, new_scratch), so that the kernels see the types they see in an
episode; the bodies' positions, angles and velocities are then set by hand. Expected results
are worked out here from the physics (nearest ground point, impulses through a rigid body's
mass and inertia, Coulomb friction, mass-weighted projections), not read back from the kernels.
Friction and restitution are given explicitly wherever a result depends on them (their
defaults are fitted and may change); the area limit and the actuation ranges are read from the
packed parameters, so that the tests follow the defaults.

A contact's impulse is solved for the normal and the friction part together (an impulse along
either direction at an off-centre point turns the body, which moves the point along the other
direction too): the tests find it from the point's 2 x 2 response matrix (:func:`respond`).

A body's state is (x, y, angle) and (vx, vy, angular velocity). Where a correction acts at a
point that is not in line with the body's centre of mass along the correction, the body also
turns, and the kernels are exact only to first order in that turn: those cases are checked
through the linearised displacement of the point (centre shift + turn x offset), which the
kernels make exact, and through momentum balances, which hold exactly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.sim.body import Body
from somite.sim.config import BLOCK_INERTIA, BLOCK_SIDE, CORNER_MASS, VOXEL_SIDE, pack_params
from somite.sim.physics import (
    CONTACT_TOLERANCE,
    RESTITUTION_SPEED,
    keep_apart,
    keep_orientation,
    keep_ropes,
    segment_near,
    set_rest_lengths,
    settle,
    spring_length,
    tip_contact,
    tip_extent,
    touch,
    turn,
    vertex_contact,
)
from somite.sim.robot import ground_view, new_scratch, robot_view
from somite.sim.system import (
    SPRING_CENTRAL,
    SPRING_CROSS,
    SPRING_SIDE,
    compile_system,
    geometry,
)
from somite.sim.terrain import Terrain

from .conftest import quiet

WALL = 100.0
HALF = BLOCK_SIDE / 2
CORNER_REACH = HALF * math.sqrt(2.0)  # a block's corner from its centre
UP = np.array([0.0, 1.0])


def terrain(*vertices: tuple[float, float]) -> Terrain:
    """A terrain through ``vertices`` with the usual walls at x = 0 and 10 m past the last."""
    xs = [0.0] + [x for x, _ in vertices] + [vertices[-1][0] + 10.0]
    ys = [vertices[0][1] + WALL] + [y for _, y in vertices] + [vertices[-1][1] + WALL]
    return Terrain("hand-made", np.array(xs), np.array(ys))


FLAT = terrain((10.0, 0.0), (1990.0, 0.0))


def peak_at(x: float, y: float) -> Terrain:
    """Flat ground at 0 with one sharp peak at (x, y)."""
    return terrain((10.0, 0.0), (x - 1.0, 0.0), (x, y), (x + 1.0, 0.0), (1990.0, 0.0))


def kit(ground_terrain=FLAT, shape="1", **options):
    """Robot, ground, scratch and params of one ``shape`` body on ``ground_terrain``."""
    params = pack_params(quiet(**options))
    system = compile_system([Body.build(shape, "none")], [ground_terrain])
    robot = robot_view(system, 0, params)
    return robot, ground_view(system, 0), new_scratch(robot), params


def at_rest(shape: str, x0: float, y0: float) -> np.ndarray:
    """(P, 3) body states at rest, unrotated, the lattice's SW corner at (x0, y0)."""
    g = geometry(Body.build(shape, "none"))
    pos = np.zeros((len(g.points), 3))
    pos[:, :2] = g.points * VOXEL_SIDE + g.centre + [x0, y0]
    return pos


def rot(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def world(pos, p, offset) -> np.ndarray:
    """World position of ``offset`` (body frame) of body p."""
    return pos[p, :2] + rot(pos[p, 2]) @ np.asarray(offset)


def point_velocity(pos, vel, p, point) -> np.ndarray:
    """Velocity of body p's material point now at ``point``."""
    r = np.asarray(point) - pos[p, :2]
    return vel[p, :2] + vel[p, 2] * np.array([-r[1], r[0]])


def linear_shift(before, after, p, point) -> np.ndarray:
    """Displacement of body p's point ``point`` to first order in the body's turn (the turn
    also moves an off-centre point sideways)."""
    r = np.asarray(point) - before[p, :2]
    turn_angle = after[p, 2] - before[p, 2]
    return after[p, :2] - before[p, :2] + turn_angle * np.array([-r[1], r[0]])


def aim(robot, pos, f, point, direction) -> int:
    """Put outline vertex f at ``point``, its body turned so that the vertex lies along
    ``direction`` (a unit vector) from the body's centre of mass. Returns the body."""
    p = robot.tip_body[f]
    offset = robot.tip_offset[f]
    pos[p, 2] = math.atan2(direction[1], direction[0]) - math.atan2(offset[1], offset[0])
    pos[p, :2] = np.asarray(point) - np.hypot(*offset) * np.asarray(direction)
    np.testing.assert_allclose(world(pos, p, offset), point, atol=1e-14)
    return p


def sync(robot, scratch, pos):
    """Each body's rotation into the scratch arrays, as substep does before the limits."""
    turn(robot.n_points, pos, scratch.cos, scratch.sin)


def apply(robot, scratch, pos, vel):
    """settle as substep calls it: each body takes the mean of its contacts' corrections."""
    settle(robot.n_points, scratch.dpos, scratch.dvel, scratch.hits, pos, vel, scratch.cos,
           scratch.sin)
    assert not scratch.dpos.any() and not scratch.dvel.any() and not scratch.hits.any()


def find_tips(robot, ground, scratch, pos, vel, params):
    """tip_contact as substep calls it (the leftmost segment and extent of the outline)."""
    sync(robot, scratch, pos)
    lo_x, hi_x, _ = tip_extent(robot, pos, scratch.cos, scratch.sin)
    first = segment_near(ground.xs, ground.n, lo_x, 0)
    scratch.contact[:] = False
    scratch.segment[:] = 0
    tip_contact(robot, ground, scratch, pos, vel, first, hi_x, params)


def run_tips(robot, ground, scratch, pos, vel, params):
    """tip_contact as substep calls it, then settle."""
    find_tips(robot, ground, scratch, pos, vel, params)
    apply(robot, scratch, pos, vel)


def run_vertices(robot, ground, scratch, pos, vel, params, lo_y=None, hi_x=None):
    """vertex_contact as substep calls it, unless ``lo_y`` or ``hi_x`` are given."""
    sync(robot, scratch, pos)
    lo_x, right, lowest = tip_extent(robot, pos, scratch.cos, scratch.sin)
    first = segment_near(ground.xs, ground.n, lo_x, 0)
    scratch.contact[:] = False
    vertex_contact(robot, ground, scratch, pos, vel, first, right if hi_x is None else hi_x,
                   lowest if lo_y is None else lo_y, params)
    apply(robot, scratch, pos, vel)


def momenta(robot, pos, vel) -> np.ndarray:
    """Linear momentum and angular momentum about the origin (px, py, L)."""
    mass = robot.mass
    inertia = 1.0 / robot.inv_inertia
    px = float(np.sum(mass * vel[:, 0]))
    py = float(np.sum(mass * vel[:, 1]))
    spin = float(np.sum(inertia * vel[:, 2] + mass * (pos[:, 0] * vel[:, 1]
                                                      - pos[:, 1] * vel[:, 0])))
    return np.array([px, py, spin])


def moments(robot, before, after) -> np.ndarray:
    """The same balance for a position correction: sum of m dx, m dy and I dtheta + m x x dx
    (zero when the correction is a pair of opposite pushes along one line)."""
    mass = robot.mass
    inertia = 1.0 / robot.inv_inertia
    d = after - before
    return np.array([
        float(np.sum(mass * d[:, 0])),
        float(np.sum(mass * d[:, 1])),
        float(np.sum(inertia * d[:, 2] + mass * (before[:, 0] * d[:, 1]
                                                 - before[:, 1] * d[:, 0]))),
    ])


def friction_factor(robot, p, r_tangent: float) -> float:
    """How much more a unit tangential impulse changes the tangential velocity of a point at
    tangential lever arm ``r_tangent`` than it changes the centre's: 1 + m r^2 / I."""
    return 1.0 + robot.mass[p] * r_tangent**2 * robot.inv_inertia[p]


def slid(v_tangent: float, v_normal: float, mu: float, factor: float) -> float:
    """Tangential speed left at a contact point whose lever arm lies along the normal, after a
    plastic impact that stops ``v_normal`` (< 0): Coulomb friction mu times the normal
    impulse m |v_n| takes at most mu |v_n| factor off the point's sliding."""
    return math.copysign(max(0.0, abs(v_tangent) - mu * abs(v_normal) * factor), v_tangent)


def impulse_of(robot, p, before, after) -> tuple[np.ndarray, float]:
    """The impulse (J, angular impulse about the centre) that changed body p's velocity."""
    return robot.mass[p] * (after[p, :2] - before[p, :2]), (after[p, 2] - before[p, 2]) / \
        robot.inv_inertia[p]


def response(robot, p, arm) -> np.ndarray:
    """K (2 x 2): the velocity change of body p's point at offset ``arm`` from its centre per
    unit impulse there, J / m + ((arm x J) / I) (-arm_y, arm_x)."""
    perp = np.array([-arm[1], arm[0]])
    return robot.inv_mass[p] * np.eye(2) + robot.inv_inertia[p] * np.outer(perp, perp)


def tangent_of(normal) -> np.ndarray:
    return np.array([normal[1], -normal[0]])


def respond(robot, p, arm, normal, v_point, mu, restitution) -> tuple[np.ndarray, bool]:
    """The ground's impulse J on body p's point at offset ``arm`` that approaches the ground
    (normal ``normal``) at velocity ``v_point``, and whether the point sticks.

    The point's normal velocity after the impulse is 0, or ``restitution`` times its approach
    above RESTITUTION_SPEED. It sticks (its tangential velocity becomes 0 too) when the
    impulse that does both lies in the Coulomb cone (|J_t| <= mu J_n); otherwise it slides,
    and the impulse lies on the cone's edge on the side against its sliding."""
    normal = np.asarray(normal, dtype=float)
    tangent = tangent_of(normal)
    vn, vt = v_point @ normal, v_point @ tangent
    assert vn < 0.0
    want = (-restitution * vn if vn < -RESTITUTION_SPEED else 0.0) * normal
    k = response(robot, p, arm)
    stick = np.linalg.solve(k, want - v_point)
    if stick @ normal >= 0.0 and abs(stick @ tangent) <= mu * (stick @ normal):
        return stick, True
    assert mu == 0.0 or vt != 0.0
    edge = normal - math.copysign(mu, vt) * tangent
    return (want - v_point) @ normal / (normal @ k @ edge) * edge, False


# touch --------------------------------------------------------------------------------------


def touch_at(robot, scratch, pos, vel, p, point, normal, depth, mu, restitution):
    """One contact of body p, found and applied (touch, then settle). ``hits`` counts it,
    and counts it as approaching when the point moves into the ground."""
    sync(robot, scratch, pos)
    start = (pos.copy(), vel.copy())
    approaching = point_velocity(pos, vel, p, point) @ np.asarray(normal) < 0.0
    touch(p, point[0], point[1], normal[0], normal[1], depth, mu, restitution, robot.inv_mass,
          robot.inv_inertia, pos, vel, scratch.dpos, scratch.dvel, scratch.hits)
    np.testing.assert_array_equal(pos, start[0])  # found now, applied by settle
    np.testing.assert_array_equal(vel, start[1])
    expected = np.zeros((robot.n_points, 2))
    expected[p] = [1.0, 1.0 if approaching else 0.0]
    np.testing.assert_array_equal(scratch.hits, expected)
    apply(robot, scratch, pos, vel)


@pytest.mark.parametrize("v_tangent", [2.0, -2.0, 6.0, -6.0])
def test_touch_under_the_centre_puts_the_point_on_the_surface_with_coulomb_friction(v_tangent):
    """The middle of a block's bottom face (0.6 m straight below the centre of mass), 0.05 m
    under flat ground, hitting it at 1 m/s: the body goes up by exactly the depth without
    turning, the point's approach stops, and friction takes at most mu times the normal
    impulse off the sliding (it sticks at 2 m/s; at 6 m/s it slides on, with mu = 1.5). The
    point is in line with the centre along the normal, so the normal impulse does not move it
    along the ground, and the friction impulse does not move it along the normal."""
    robot, _, scratch, params = kit()
    mu = 1.5
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [12.0, 0.55, 0.0]
    point = np.array([12.0, -0.05])
    vel = np.zeros((4, 3))
    vel[0] = [v_tangent, -1.0, 0.0]
    old_pos, old_vel = pos.copy(), vel.copy()
    touch_at(robot, scratch, pos, vel, 0, point, UP, 0.05, mu, params.restitution)
    np.testing.assert_allclose(pos[0], [12.0, 0.6, 0.0], atol=1e-15)
    assert (scratch.cos[0], scratch.sin[0]) == (1.0, 0.0)
    v = point_velocity(pos, vel, 0, point + [0.0, 0.05])
    factor = friction_factor(robot, 0, 0.6)
    assert factor == pytest.approx(2.5)
    assert abs(v_tangent) < mu * factor if abs(v_tangent) == 2.0 else abs(v_tangent) > mu * factor
    np.testing.assert_allclose(v, [slid(v_tangent, -1.0, mu, factor), 0.0], atol=1e-14)
    j, spin = impulse_of(robot, 0, old_vel, vel)
    assert j[1] == pytest.approx(robot.mass[0] * 1.0, abs=1e-15)  # no bounce at 1 m/s
    assert abs(j[0]) <= mu * j[1] * (1 + 1e-12)
    assert spin == pytest.approx(cross(point - old_pos[0, :2], j), abs=1e-15)
    np.testing.assert_array_equal(pos[1:], old_pos[1:])  # the other bodies are not touched
    np.testing.assert_array_equal(vel[1:], old_vel[1:])


def test_touch_of_a_point_leaving_the_ground_keeps_its_velocity():
    robot, _, scratch, params = kit()
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [12.0, 0.57, 0.3]
    vel = np.zeros((4, 3))
    for v in ([1.0, 0.5, 0.0], [0.3, 0.1, 0.0], [-2.0, 0.0, 0.0], [0.0, 0.2, 3.0]):
        vel[0] = v
        point = world(pos, 0, [0.6, -0.6])
        assert point_velocity(pos, vel, 0, point)[1] >= 0.0
        state = pos.copy()
        touch_at(robot, scratch, state, vel, 0, point, UP, 0.03, params.friction, 1.0)
        np.testing.assert_array_equal(vel[0], v)
        assert linear_shift(pos, state, 0, point)[1] == pytest.approx(0.03, abs=1e-15)


@pytest.mark.parametrize("speed", [0.5 * RESTITUTION_SPEED, RESTITUTION_SPEED,
                                   1.5 * RESTITUTION_SPEED, 4.0 * RESTITUTION_SPEED])
def test_touch_bounces_only_above_the_restitution_speed(speed):
    robot, _, scratch, params = kit()
    e = 0.4
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [12.0, 0.59, 0.0]
    point = np.array([12.0, -0.01])
    vel = np.zeros((4, 3))
    vel[0] = [0.0, -speed, 0.0]
    touch_at(robot, scratch, pos, vel, 0, point, UP, 0.01, params.friction, e)
    bounce = e * speed if speed > RESTITUTION_SPEED else 0.0
    np.testing.assert_allclose(vel[0], [0.0, bounce, 0.0], atol=1e-15)


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_touch_off_centre_turns_the_body_away_from_the_ground(side):
    """A block's bottom-right (side 1) or bottom-left (side -1) corner pushed up turns the
    body counter-clockwise or clockwise; the point itself moves up by the depth to first
    order, and without friction its approach stops exactly."""
    robot, _, scratch, params = kit()
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [12.0, 0.58, 0.0]
    vel = np.zeros((4, 3))
    vel[0] = [0.0, -1.0, 0.0]
    old_pos, old_vel = pos.copy(), vel.copy()
    point = world(pos, 0, [side * HALF, -HALF])
    depth = 0.02
    touch_at(robot, scratch, pos, vel, 0, point, UP, depth, 0.0, params.restitution)
    assert np.sign(pos[0, 2]) == side and np.sign(vel[0, 2]) == side
    assert pos[0, 0] == old_pos[0, 0] and vel[0, 0] == 0.0
    assert linear_shift(old_pos, pos, 0, point)[1] == pytest.approx(depth, abs=1e-15)
    # The point is then within the second-order error of the turn from the surface.
    surface_gap = world(pos, 0, [side * HALF, -HALF])[1] - (point[1] + depth)
    assert abs(surface_gap) <= pos[0, 2] ** 2 * CORNER_REACH
    # The point's approach is stopped, through the body's effective mass at the point.
    assert point_velocity(pos, vel, 0, point + [0.0, depth])[1] == pytest.approx(0.0, abs=1e-14)
    j, spin = impulse_of(robot, 0, old_vel, vel)
    arm = point - old_pos[0, :2]
    assert spin == pytest.approx(cross(arm, j), abs=1e-15)
    w = robot.inv_mass[0] + arm[0] ** 2 * robot.inv_inertia[0]
    assert j[1] == pytest.approx(1.0 / w, abs=1e-15)
    assert scratch.cos[0] == math.cos(pos[0, 2]) and scratch.sin[0] == math.sin(pos[0, 2])


@pytest.mark.parametrize("velocity, mu, sticks", [
    ((3.0, -1.0, 2.0), 1.5, True),  # approaching at 4.05 m/s: bounces
    ((0.2, -0.3, 0.0), 1.5, True),
    ((1.0, -2.0, -3.0), 1.5, False),
    ((-0.5, -2.0, 1.0), 0.3, False),  # bounces
    ((0.2, -0.3, 0.0), 0.3, False),
])
def test_touch_momentum_change_is_an_impulse_at_the_contact_point(velocity, mu, sticks):
    """A block corner under a 3-4-5 slope: the linear and the angular momentum (about the
    centre of mass) change as one impulse at the contact point would change them, and so does
    the position correction; the impulse pushes out of the ground, its tangential part is at
    most mu times its normal part, and it is the point's impulse of :func:`respond`: the
    point's normal velocity ends at 0 (or bounces back) whether it sticks or slides; a sticking
    point stops along the ground too, a sliding one takes friction mu J_n against its
    sliding."""
    robot, _, scratch, _ = kit()
    e = 0.4
    normal = np.array([-0.6, 0.8])
    tangent = np.array([0.8, 0.6])
    assert np.array_equal(tangent, tangent_of(normal))
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [32.3, 2.2, 0.4]
    vel = np.zeros((4, 3))
    vel[0] = velocity
    point = world(pos, 0, [-HALF, -HALF])
    old_pos, old_vel = pos.copy(), vel.copy()
    v_before = point_velocity(pos, vel, 0, point)
    vn, vt = v_before @ normal, v_before @ tangent
    assert vn < 0.0
    touch_at(robot, scratch, pos, vel, 0, point, normal, 0.04, mu, e)
    arm = point - old_pos[0, :2]
    assert abs(cross(arm, normal)) > 0.7 and abs(cross(arm, tangent)) > 0.4  # coupled
    shift, turned = impulse_of(robot, 0, old_pos, pos)
    assert cross(shift, normal) == pytest.approx(0.0, abs=1e-15)
    assert shift @ normal > 0.0
    assert turned == pytest.approx(cross(arm, shift), abs=1e-15)
    assert linear_shift(old_pos, pos, 0, point) @ normal == pytest.approx(0.04, abs=1e-13)
    j, spin = impulse_of(robot, 0, old_vel, vel)
    assert spin == pytest.approx(cross(arm, j), abs=1e-14)
    jn, jt = j @ normal, j @ tangent
    assert jn > 0.0
    assert abs(jt) <= mu * jn * (1 + 1e-12)
    expected, stuck = respond(robot, 0, arm, normal, v_before, mu, e)
    assert stuck == sticks
    np.testing.assert_allclose(j, expected, rtol=1e-12, atol=1e-14)
    v_after = point_velocity(old_pos, vel, 0, point)  # measured where it was decided
    bounce = -e * vn if vn < -RESTITUTION_SPEED else 0.0
    assert v_after @ normal == pytest.approx(bounce, abs=1e-14)
    if sticks:
        assert v_after @ tangent == pytest.approx(0.0, abs=1e-14)
    else:
        assert abs(jt) == pytest.approx(mu * jn, rel=1e-12)
        assert jt * vt < 0.0 and v_after @ tangent * vt > 0.0  # against the sliding; slides on


STICKING_CASES = [
    # the body's angle, its velocity, mu: the bottom-left block corner approaching flat ground
    (0.0, (-1.0, -1.0, 0.0), 1.5),
    (0.0, (1.0, -1.0, 0.0), 1.5),
    (0.0, (-1.0, -2.0, 0.0), 1.5),  # bounces
    (0.3, (0.5, -0.6, -1.0), 1.5),
    (0.3, (0.3, -0.2, 1.0), 1.5),
    (0.3, (-3.0, -2.0, 0.0), 0.8),  # bounces
]
SLIDING_CASES = [
    (0.0, (-1.0, -1.0, 0.0), 0.3),
    (0.0, (1.0, -0.5, 0.0), 0.3),
    (0.0, (-1.0, -2.0, 0.0), 0.3),  # bounces
    (0.0, (4.0, -0.5, 1.0), 1.5),  # bounces
    (0.3, (0.5, -0.6, -1.0), 0.3),
    (0.3, (4.0, -0.5, 1.0), 1.5),
]


def corner_contact(angle, velocity, mu):
    """Body 0 turned by ``angle``, its block's bottom-left corner 0.02 m under flat ground and
    approaching it: touch and settle with mu and restitution 0.4. The corner is off the
    centre both along the normal and along the ground, so either impulse also moves it along
    the other direction. Returns the states before and after, the corner and its
    velocity before, the impulse it took, and whether it sticks (:func:`respond`)."""
    robot, _, scratch, _ = kit()
    pos = at_rest("1", 11.0, 1.0)
    pos[0] = [12.0, 0.6, angle]
    pos[0, 1] -= world(pos, 0, [-HALF, -HALF])[1] + 0.02
    vel = np.zeros((4, 3))
    vel[0] = velocity
    point = world(pos, 0, [-HALF, -HALF])
    assert point[1] == pytest.approx(-0.02, abs=1e-15)
    arm = point - pos[0, :2]
    assert abs(arm[0]) > 0.3 and abs(arm[1]) > 0.3
    v_before = point_velocity(pos, vel, 0, point)
    assert v_before[1] < 0.0
    old_pos, old_vel = pos.copy(), vel.copy()
    touch_at(robot, scratch, pos, vel, 0, point, UP, 0.02, mu, 0.4)
    expected, sticks = respond(robot, 0, arm, UP, v_before, mu, 0.4)
    j, spin = impulse_of(robot, 0, old_vel, vel)
    assert spin == pytest.approx(cross(arm, j), abs=1e-14)
    np.testing.assert_allclose(j, expected, rtol=1e-12, atol=1e-14)
    return (old_pos, old_vel), (pos, vel), point, v_before, j, sticks


@pytest.mark.parametrize("angle, velocity, mu", STICKING_CASES)
def test_sticking_corner_stops_exactly(angle, velocity, mu):
    """Where friction can hold it, the corner stops altogether: no velocity left along the
    ground or into it (or it bounces straight back, restitution 0.4 of an approach faster
    than RESTITUTION_SPEED), with an impulse inside the Coulomb cone."""
    before, after, point, v_before, j, sticks = corner_contact(angle, velocity, mu)
    assert sticks
    assert 0.0 < j[1] and abs(j[0]) <= mu * j[1]
    bounce = -0.4 * v_before[1] if v_before[1] < -RESTITUTION_SPEED else 0.0
    np.testing.assert_allclose(point_velocity(before[0], after[1], 0, point), [0.0, bounce],
                               atol=1e-14)


@pytest.mark.parametrize("angle, velocity, mu", SLIDING_CASES)
def test_sliding_corner_ends_with_zero_normal_velocity_and_friction_at_mu(angle, velocity, mu):
    """Where friction cannot hold it, the corner slides on, the same way: friction is exactly
    mu times the normal impulse, against the sliding, and the normal impulse still stops the
    corner's approach exactly (or bounces it back), friction's turn included (1x1 body, corner
    sliding at (-1, -1), mu 0.3: it does not keep moving into the ground)."""
    before, after, point, v_before, j, sticks = corner_contact(angle, velocity, mu)
    assert not sticks
    assert j[1] > 0.0
    assert abs(j[0]) == pytest.approx(mu * j[1], rel=1e-12)
    assert j[0] * v_before[0] < 0.0
    v_after = point_velocity(before[0], after[1], 0, point)
    bounce = -0.4 * v_before[1] if v_before[1] < -RESTITUTION_SPEED else 0.0
    assert v_after[1] == pytest.approx(bounce, abs=1e-14)
    assert v_after[0] * v_before[0] > 0.0


# tip_contact --------------------------------------------------------------------------------


def test_tip_below_flat_ground_goes_straight_up_and_tips_near_it_are_flagged():
    """Body 0 stands on its block's outer corner (turned 45 degrees, so the corner is straight
    below its centre of mass), 0.05 m in the ground and sliding: it goes up by exactly 0.05
    without turning, and friction stops the corner's sliding (mu |v_n| (1 + m r^2 / I) is
    more than 2 m/s at mu = 1.5). Body 1's lowest corner within CONTACT_TOLERANCE above the
    ground counts as touching and is not moved; body 2's, just above the tolerance, does not."""
    robot, ground, scratch, params = kit(friction=1.5)
    mu = params.friction
    pos = at_rest("1", 11.0, 1.0)
    p = aim(robot, pos, 0, [12.0, -0.05], -UP)
    assert p == 0
    pos[1, 1] = HALF + 0.5 * CONTACT_TOLERANCE
    pos[2, 1] = HALF + 1.5 * CONTACT_TOLERANCE
    vel = np.zeros((4, 3))
    vel[:, :2] = [[2.0, -1.0], [1.0, -0.5], [0.7, -2.0], [0.4, -0.5]]
    old_pos, old_vel = pos.copy(), vel.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[0], old_pos[0] + [0.0, 0.05, 0.0], atol=1e-14)
    contact = np.array([12.0, 0.0])
    factor = friction_factor(robot, 0, CORNER_REACH)
    assert 2.0 < mu * factor
    np.testing.assert_allclose(point_velocity(pos, vel, 0, contact), [0.0, 0.0], atol=1e-14)
    np.testing.assert_array_equal(pos[1:], old_pos[1:])
    np.testing.assert_array_equal(vel[1:], old_vel[1:])
    assert scratch.contact.tolist() == [True, True, False, False]


SLOPE = terrain((10.0, 0.0), (30.0, 0.0), (34.0, 3.0), (1990.0, 3.0))


@pytest.mark.parametrize("v_tangent", [3.0, 8.0])
def test_tip_below_a_slope_goes_out_along_its_normal(v_tangent):
    """On a 3-4-5 slope, out along the unit normal (-3, 4) / 5 by the depth across the slope;
    friction along (4, 3) / 5 (sticking at 3 m/s, sliding at 8 m/s; an approach at 0.8 m/s,
    under RESTITUTION_SPEED, so no bounce; mu = 1.5)."""
    robot, ground, scratch, params = kit(SLOPE, friction=1.5)
    mu = params.friction
    normal = np.array([-0.6, 0.8])
    tangent = np.array([0.8, 0.6])
    surface = np.array([32.0, 1.5])
    pos = at_rest("1", 30.0, 6.0)
    p = aim(robot, pos, 0, surface - 0.1 * normal, -normal)
    vel = np.zeros((4, 3))
    vel[p, :2] = v_tangent * tangent - 0.8 * normal
    old_pos = pos.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[p], old_pos[p] + [*(0.1 * normal), 0.0], atol=1e-14)
    v = point_velocity(pos, vel, p, surface)
    expected = slid(v_tangent, -0.8, mu, friction_factor(robot, p, CORNER_REACH))
    np.testing.assert_allclose(v, expected * tangent, atol=1e-14)
    assert (expected == 0.0) == (v_tangent == 3.0)
    np.testing.assert_array_equal(pos[1:], old_pos[1:])
    assert scratch.contact.tolist() == [True, False, False, False]


def test_tip_near_a_steep_wall_goes_sideways_to_the_nearest_segment():
    """Under the plateau 0.5 m deep but 0.1 m from the wall's face: out through the face, to
    the nearest ground point, not 0.5 m up; friction along the face (sliding at mu = 1.5)."""
    a, b = np.array([20.0, 0.0]), np.array([20.1, 10.0])
    wall = terrain((10.0, 0.0), tuple(a), tuple(b), (40.0, 10.0), (1990.0, 10.0))
    robot, ground, scratch, params = kit(wall, friction=1.5)
    mu = params.friction
    s = b - a
    corner = np.array([20.2, 9.5])
    u = (corner - a) @ s / (s @ s)
    nearest = a + u * s
    out = (nearest - corner) / np.hypot(*(nearest - corner))
    along = np.array([out[1], -out[0]])
    pos = at_rest("1", 11.0, 3.0)  # the other bodies in the air left of the wall
    p = aim(robot, pos, 0, corner, -out)
    vel = np.zeros((4, 3))
    vel[p, :2] = [1.0, 8.0]  # into the wall and up along it
    vn, vt = vel[p, :2] @ out, vel[p, :2] @ along
    old_pos = pos.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    assert 0.0 < u < 1.0 and vn < 0.0
    np.testing.assert_allclose(pos[p] - old_pos[p], [*(nearest - corner), 0.0], atol=1e-12)
    moved = pos[p, :2] - old_pos[p, :2]
    assert moved[0] < -0.09 and abs(moved[1]) < 0.01
    expected = slid(vt, vn, mu, friction_factor(robot, p, CORNER_REACH))
    assert expected != 0.0
    np.testing.assert_allclose(point_velocity(pos, vel, p, nearest), expected * along,
                               atol=1e-12)
    assert scratch.contact.tolist() == [True, False, False, False]


def test_tip_under_a_valley_vertex_is_pushed_straight_up_to_it():
    """Straight below the bottom vertex of a symmetric valley: the nearest ground point is the
    vertex, so the push is straight up (neither slope's normal) and the corner stops without
    sliding either way."""
    valley = terrain((10.0, 0.0), (20.0, 0.0), (22.0, -1.0), (24.0, 0.0), (1990.0, 0.0))
    robot, ground, scratch, params = kit(valley)
    pos = at_rest("1", 17.0, 3.0)
    p = aim(robot, pos, 0, [22.0, -1.05], -UP)
    vel = np.zeros((4, 3))
    vel[p] = [0.0, -0.8, 0.0]
    old_pos = pos.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[p], old_pos[p] + [0.0, 0.05, 0.0], atol=1e-14)
    np.testing.assert_allclose(vel[p], [0.0, 0.0, 0.0], atol=1e-15)
    assert scratch.contact.tolist() == [True, False, False, False]


def test_tips_of_a_resting_body_just_above_flat_ground_only_touch():
    """The 1-voxel body at rest with its bottom within CONTACT_TOLERANCE of flat ground: the
    two bottom bodies touch, nothing moves."""
    robot, ground, scratch, params = kit()
    pos = at_rest("1", 11.0, 0.5 * CONTACT_TOLERANCE)
    vel = np.zeros((4, 3))
    start = pos.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(pos, start)
    np.testing.assert_array_equal(vel, np.zeros((4, 3)))
    assert scratch.contact.tolist() == [True, True, False, False]


@pytest.mark.parametrize("mu, rise", [(0.0, 0.4), (1.5, 0.625)])
def test_a_body_with_two_contacts_takes_the_mean_of_their_corrections(mu, rise):
    """Blocks lying flat 0.05 m in the ground and falling at 1 m/s. Alone, each bottom corner
    would lift its body by 0.05 m at the corner, turning it; the turns cancel in the mean, which
    lifts the body straight by the depth times (1/m) / (1/m + r_n^2 / I) = 0.4. Alone, each
    corner's impulse would stop its approach (no bounce at 1 m/s), turning the body: without
    friction, the mean takes 0.4 m/s off the fall; with friction enough to hold the corners,
    each stops altogether, its friction resisting the turn, which takes a larger impulse: the
    mean takes (1/m + r^2 / I) / (1/m + 2 r^2 / I) = 0.625 m/s off the fall (the turns and the
    frictions cancel in the mean)."""
    robot, ground, scratch, params = kit(friction=mu)
    pos = at_rest("1", 11.0, -0.05)
    vel = np.zeros((4, 3))
    vel[:, 1] = -1.0
    start, start_vel = pos.copy(), vel.copy()
    find_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(scratch.hits, [[2.0, 2.0], [2.0, 2.0], [0.0, 0.0], [0.0, 0.0]])
    apply(robot, scratch, pos, vel)
    share = robot.inv_mass[0] / (robot.inv_mass[0] + HALF**2 * robot.inv_inertia[0])
    assert share == pytest.approx(0.4)
    for p in (0, 1):
        np.testing.assert_allclose(pos[p], start[p] + [0.0, share * 0.05, 0.0], atol=1e-14)
        impulses = [respond(robot, p, np.array([sx * HALF, -HALF]), UP, start_vel[p, :2], mu,
                            params.restitution) for sx in (-1.0, 1.0)]
        assert all(sticks == (mu > 0.0) for _, sticks in impulses)
        j = np.mean([j for j, _ in impulses], axis=0)
        assert j[0] == pytest.approx(0.0, abs=1e-15)
        assert j[1] * robot.inv_mass[p] == pytest.approx(rise, abs=1e-14)
        np.testing.assert_allclose(vel[p], [0.0, -1.0 + rise, 0.0], atol=1e-14)
    np.testing.assert_array_equal(pos[2:], start[2:])
    np.testing.assert_array_equal(vel[2:], np.tile([0.0, -1.0, 0.0], (2, 1)))
    assert scratch.contact.tolist() == [True, True, False, False]


@pytest.mark.parametrize("velocity, mu, sticks", [((-0.3, -0.2, 1.0), 1.5, True),
                                                  ((0.3, -0.2, 1.0), 1.5, False),
                                                  ((0.3, -0.2, 1.0), 0.3, False)])
def test_a_leaving_contact_does_not_dilute_another_contacts_impulse(velocity, mu, sticks):
    """Body 0 lying flat 0.05 m in the ground and spinning counter-clockwise: its bottom-left
    corner moves into the ground, its bottom-right corner out of it. Both push it out (the
    mean of the two pushes lifts it straight), but only the approaching corner takes an
    impulse, and the body takes all of it, as if it were its only contact: that corner's
    approach stops (and, where it sticks, its sliding), not half of it."""
    robot, ground, scratch, params = kit(friction=mu, restitution=0.4)
    pos = at_rest("1", 11.0, 3.0)
    pos[0] = [12.0, HALF - 0.05, 0.0]
    vel = np.zeros((4, 3))
    vel[0] = velocity
    left = world(pos, 0, [-HALF, -HALF])
    right = world(pos, 0, [HALF, -HALF])
    v_left = point_velocity(pos, vel, 0, left)
    assert v_left[1] < 0.0 < point_velocity(pos, vel, 0, right)[1]
    old_pos, old_vel = pos.copy(), vel.copy()
    find_tips(robot, ground, scratch, pos, vel, params)
    np.testing.assert_array_equal(scratch.hits, [[2.0, 1.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    apply(robot, scratch, pos, vel)
    share = robot.inv_mass[0] / (robot.inv_mass[0] + HALF**2 * robot.inv_inertia[0])
    np.testing.assert_allclose(pos[0], old_pos[0] + [0.0, share * 0.05, 0.0], atol=1e-14)
    arm = left - old_pos[0, :2]
    expected, stuck = respond(robot, 0, arm, UP, v_left, mu, 0.4)
    assert stuck == sticks
    j, spin = impulse_of(robot, 0, old_vel, vel)
    np.testing.assert_allclose(j, expected, rtol=1e-12, atol=1e-14)
    assert spin == pytest.approx(cross(arm, expected), abs=1e-14)
    v_after = point_velocity(old_pos, vel, 0, left)
    assert v_after[1] == pytest.approx(0.0, abs=1e-14)  # approached at under 1 m/s
    if sticks:
        assert v_after[0] == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_array_equal(pos[1:], old_pos[1:])
    np.testing.assert_array_equal(vel[1:], old_vel[1:])


def test_mirror_images_move_as_mirror_images():
    """Body 0 tilted, both its bottom corners in the ground, sliding and spinning; body 1 its
    mirror image about x = 13 (its outline vertices are listed in another order). Found from
    one state and averaged, the contacts do not depend on their order: the results mirror."""
    robot, ground, scratch, params = kit()
    pos = at_rest("1", 11.0, 3.0)
    vel = np.zeros((4, 3))
    pos[0] = [12.0, 0.48, 0.15]
    vel[0] = [0.7, -1.2, 0.5]
    mirror = np.array([-1.0, 1.0, -1.0])
    pos[1] = mirror * pos[0] + [26.0, 0.0, 0.0]
    vel[1] = mirror * vel[0]
    for p in (0, 1):
        depths = [-world(pos, p, [sx * HALF, -HALF])[1] for sx in (-1, 1)]
        assert min(depths) > 0.0 and max(depths) > 0.1
    old = pos.copy()
    run_tips(robot, ground, scratch, pos, vel, params)
    assert pos[0, 1] > old[0, 1] and pos[0, 2] != old[0, 2]
    np.testing.assert_allclose(pos[1], mirror * pos[0] + [26.0, 0.0, 0.0], atol=1e-13)
    np.testing.assert_allclose(vel[1], mirror * vel[0], atol=1e-13)
    assert scratch.contact.tolist() == [True, True, False, False]


# vertex_contact -----------------------------------------------------------------------------


LOCAL_CASES = [
    # vertex in the block's frame, the direction the block leaves in (its frame), the depth
    ((0.0, -0.5), (0.0, 1.0), 0.1),
    ((0.45, 0.0), (-1.0, 0.0), 0.15),
    ((-0.5, 0.0), (1.0, 0.0), 0.1),
    ((0.0, 0.55), (0.0, -1.0), 0.05),
]


@pytest.mark.parametrize("angle", [0.0, 0.5, -1.0])
@pytest.mark.parametrize("local, leave, depth", LOCAL_CASES)
def test_vertex_in_a_block_pushes_it_out_through_the_nearest_edge(angle, local, leave, depth):
    """A crest vertex inside body 0's block (its centre is the body's centre of mass), on the
    block's axis through the centre: the body moves by exactly the depth along the nearest
    edge's normal, in the block's frame, without turning; its approach stops; the vertex ends
    on that edge."""
    pos = at_rest("1", 13.0, 2.0)
    pos[0, 2] = angle
    vertex = pos[0, :2] + rot(angle) @ local
    robot, ground, scratch, params = kit(peak_at(*vertex))
    out = rot(angle) @ leave
    vel = np.zeros((4, 3))
    vel[0, :2] = -0.8 * out  # approaching under RESTITUTION_SPEED: no bounce
    old_pos, old_vel = pos.copy(), vel.copy()
    run_vertices(robot, ground, scratch, pos, vel, params)
    np.testing.assert_allclose(pos[0], old_pos[0] + [*(depth * out), 0.0], atol=1e-14)
    np.testing.assert_allclose(vel[0], [0.0, 0.0, 0.0], atol=1e-14)
    inside = rot(-angle) @ (vertex - pos[0, :2])
    assert np.max(np.abs(inside)) == pytest.approx(HALF, abs=1e-14)
    np.testing.assert_array_equal(pos[1:], old_pos[1:])
    np.testing.assert_array_equal(vel[1:], old_vel[1:])
    assert scratch.contact.tolist() == [True, False, False, False]


@pytest.mark.parametrize("local, leave", [((0.35, -0.45), (0.0, 1.0)),
                                          ((0.5, -0.4), (-1.0, 0.0)),
                                          ((-0.3, 0.52), (0.0, -1.0)),
                                          ((-0.55, 0.3), (1.0, 0.0))])
def test_vertex_off_the_axis_leaves_through_the_nearest_edge_of_a_turned_block(local, leave):
    """Off the block's axes the push turns the body too: its centre moves along the nearest
    edge's normal (in the block's frame, the block turned 0.7 rad) and the vertex's point of
    the block moves by the vertex's depth under that edge, to first order."""
    angle = 0.7
    pos = at_rest("1", 13.0, 2.0)
    pos[0, 2] = angle
    vertex = pos[0, :2] + rot(angle) @ local
    robot, ground, scratch, params = kit(peak_at(*vertex))
    out = rot(angle) @ leave
    depth = HALF - np.asarray(local) @ -np.asarray(leave)
    assert depth == min(HALF - abs(local[0]), HALF - abs(local[1]))
    vel = np.zeros((4, 3))
    old = pos.copy()
    run_vertices(robot, ground, scratch, pos, vel, params)
    moved = pos[0, :2] - old[0, :2]
    assert cross(moved, out) == pytest.approx(0.0, abs=1e-15) and moved @ out > 0.0
    assert linear_shift(old, pos, 0, vertex) @ out == pytest.approx(depth, abs=1e-14)
    assert scratch.contact.tolist() == [True, False, False, False]


def test_vertices_outside_the_blocks_are_ignored():
    """In the voxel's middle (between its blocks), just outside a block's side, and just
    outside the corner of a block turned 45 degrees (inside its bounding box)."""
    pos = at_rest("1", 13.0, 2.0)
    pos[0, 2] = math.pi / 4
    centre = pos[0, :2]
    for vertex in (pos[:, :2].mean(axis=0), pos[1, :2] + [HALF + 0.01, 0.0],
                   centre + [0.55, 0.55]):
        robot, ground, scratch, params = kit(peak_at(*vertex))
        state = pos.copy()
        vel = np.tile([0.3, -1.0, 0.5], (4, 1))
        run_vertices(robot, ground, scratch, state, vel, params)
        np.testing.assert_array_equal(state, pos)
        np.testing.assert_array_equal(vel, np.tile([0.3, -1.0, 0.5], (4, 1)))
        assert not scratch.contact.any()


def test_vertices_at_or_below_lo_y_or_right_of_hi_x_are_skipped():
    """vertex_contact trusts its bounds: a vertex inside a block is skipped when it is not
    above ``lo_y`` (the robot's lowest outline vertex in substep) or is right of ``hi_x``."""
    pos = at_rest("1", 13.0, 2.0)
    vertex = pos[0, :2] + [0.0, -0.5]
    robot, ground, scratch, params = kit(peak_at(*vertex))
    for lo_y, hi_x, acts in ((vertex[1], None, False), (vertex[1] - 1e-9, None, True),
                             (None, vertex[0] - 1e-9, False), (None, vertex[0], True)):
        state = pos.copy()
        vel = np.zeros((4, 3))
        run_vertices(robot, ground, scratch, state, vel, params, lo_y=lo_y, hi_x=hi_x)
        assert (state[0, 1] == pytest.approx(pos[0, 1] + 0.1, abs=1e-14)) == acts
        assert scratch.contact[0] == acts


# keep_apart / keep_ropes --------------------------------------------------------------------


def rope_lengths(robot, pos) -> np.ndarray:
    out = []
    for (a, b), anchor in zip(robot.rope_ends, robot.rope_anchor):
        out.append(np.hypot(*(world(pos, b, anchor[2:]) - world(pos, a, anchor[:2]))))
    return np.array(out)


def test_short_rope_is_pushed_to_the_block_side_conserving_momentum():
    """The 1-voxel body with its bottom blocks' centres 1 m apart and closing at 1.5 m/s: they
    move apart 0.1 m each to exactly BLOCK_SIDE (equal masses) and share their velocity along
    the rope; the other components and the other bodies are untouched."""
    robot, _, scratch, _ = kit()
    pos = at_rest("1", 11.0, 1.0)
    pos[1, 0] -= 0.8
    vel = np.zeros((4, 3))
    vel[0] = [1.0, 0.2, 0.0]
    vel[1] = [-0.5, 0.3, 0.0]
    old_pos, old_vel = pos.copy(), vel.copy()
    assert rope_lengths(robot, pos)[0] == pytest.approx(1.0)
    sync(robot, scratch, pos)
    keep_ropes(robot, scratch, pos, vel)
    np.testing.assert_allclose(pos[:2, 0], old_pos[:2, 0] + [-0.1, 0.1], atol=1e-14)
    assert pos[1, 0] - pos[0, 0] == pytest.approx(BLOCK_SIDE, abs=1e-14)
    np.testing.assert_allclose(vel[:2], [[0.25, 0.2, 0.0], [0.25, 0.3, 0.0]], atol=1e-15)
    np.testing.assert_array_equal(pos[:, 1:], old_pos[:, 1:])
    np.testing.assert_array_equal(pos[2:], old_pos[2:])
    np.testing.assert_array_equal(vel[2:], old_vel[2:])
    np.testing.assert_allclose(momenta(robot, old_pos, vel), momenta(robot, old_pos, old_vel),
                               atol=1e-14)
    assert np.all(rope_lengths(robot, pos) >= BLOCK_SIDE - 1e-14)


def test_short_rope_between_unequal_bodies_moves_the_lighter_one_twice_as_far():
    """Body 11: the rope from the 0.36 kg corner body to the left block of the 0.72 kg middle
    body (anchored 0.6 m left of its centre, in line with the rope: no turn)."""
    robot, _, scratch, _ = kit(shape="11")
    assert robot.mass[1] == 2 * robot.mass[0]
    pos = at_rest("11", 11.0, 1.0)
    pos[0, 0] += 0.8
    vel = np.zeros((6, 3))
    vel[0] = [0.9, 0.0, 0.0]
    old_pos, old_vel = pos.copy(), vel.copy()
    sync(robot, scratch, pos)
    keep_ropes(robot, scratch, pos, vel)
    np.testing.assert_allclose(pos[[0, 1], 0] - old_pos[[0, 1], 0], [-0.4 / 3, 0.2 / 3],
                               atol=1e-14)
    assert rope_lengths(robot, pos)[0] == pytest.approx(BLOCK_SIDE, abs=1e-14)
    np.testing.assert_allclose(vel[[0, 1], 0], [0.3, 0.3], atol=1e-15)
    np.testing.assert_array_equal(pos[:, 2], 0.0)
    np.testing.assert_array_equal(vel[:, 1:], 0.0)
    np.testing.assert_allclose(moments(robot, old_pos, pos), 0.0, atol=1e-14)
    np.testing.assert_allclose(momenta(robot, old_pos, vel), momenta(robot, old_pos, old_vel),
                               atol=1e-14)


@pytest.mark.parametrize("closing", [True, False])
def test_keep_apart_across_offset_anchors_turns_the_bodies_and_conserves_momentum(closing):
    """Two turned bodies of body 11 whose rope anchors are off their centres and across the
    rope: both bodies turn, the anchors end BLOCK_SIDE apart to first order, linear and
    angular momentum are conserved (by the position correction as well), and the anchors stop
    closing (measured at the offsets the correction was decided with); a rope that is opening
    keeps its velocities."""
    robot, _, scratch, _ = kit(shape="11")
    pos = at_rest("11", 11.0, 1.0)
    pos[1, 2] = 0.3
    pos[4, 2] = -0.2
    a, b = 1, 4
    anchor_a = np.array([0.6, 0.0])
    anchor_b = np.array([0.6, 0.0])
    ra = rot(pos[a, 2]) @ anchor_a
    pos[b, :2] = pos[a, :2] + ra + 0.9 * unit(1.2) - rot(pos[b, 2]) @ anchor_b
    rb = rot(pos[b, 2]) @ anchor_b
    vel = np.zeros((6, 3))
    sign = 1.0 if closing else -1.0
    vel[a] = sign * np.array([0.4, 1.0, -0.5])
    vel[b] = sign * np.array([-0.3, -1.2, 0.8])
    d = pos[b, :2] + rb - pos[a, :2] - ra
    n = d / np.hypot(*d)
    rel = point_velocity(pos, vel, b, pos[b, :2] + rb) - point_velocity(pos, vel, a,
                                                                         pos[a, :2] + ra)
    assert (rel @ n < 0.0) == closing
    assert abs(cross(ra, n)) > 0.1 and abs(cross(rb, n)) > 0.1
    old_pos, old_vel = pos.copy(), vel.copy()
    sync(robot, scratch, pos)
    keep_apart(a, b, ra[0], ra[1], rb[0], rb[1], BLOCK_SIDE, robot.inv_mass,
               robot.inv_inertia, pos, vel, scratch.cos, scratch.sin)
    assert pos[a, 2] != old_pos[a, 2] and pos[b, 2] != old_pos[b, 2]
    gap = (d + linear_shift(old_pos, pos, b, old_pos[b, :2] + rb)
           - linear_shift(old_pos, pos, a, old_pos[a, :2] + ra))
    assert gap @ n == pytest.approx(BLOCK_SIDE, abs=1e-14)
    np.testing.assert_allclose(moments(robot, old_pos, pos), 0.0, atol=1e-14)
    np.testing.assert_allclose(momenta(robot, old_pos, vel), momenta(robot, old_pos, old_vel),
                               atol=1e-14)
    if closing:
        rel = (point_velocity(old_pos, vel, b, old_pos[b, :2] + rb)
               - point_velocity(old_pos, vel, a, old_pos[a, :2] + ra))
        assert rel @ n == pytest.approx(0.0, abs=1e-14)
    else:
        np.testing.assert_array_equal(vel, old_vel)
    for p in (a, b):
        assert scratch.cos[p] == math.cos(pos[p, 2]) and scratch.sin[p] == math.sin(pos[p, 2])
    assert abs(rope_lengths(robot, pos)[-1] - BLOCK_SIDE) < 0.01  # rope 7 is this pair


def test_ropes_above_the_limit_are_untouched():
    robot, _, scratch, _ = kit(shape="11")
    pos = at_rest("11", 11.0, 1.0)
    pos[:, 0] = 11.0 + (pos[:, 0] - 11.0) * 0.8  # squeezed, every rope still over 1.2 m
    pos[:, 2] = [0.1, -0.05, 0.0, 0.02, 0.0, -0.1]
    assert np.all(rope_lengths(robot, pos) > BLOCK_SIDE)
    assert np.min(rope_lengths(robot, pos)) < BLOCK_SIDE + 0.3
    vel = np.tile([-1.0, 2.0, 3.0], (6, 1))
    vel[::2] *= -1.0
    start = (pos.copy(), vel.copy())
    sync(robot, scratch, pos)
    keep_ropes(robot, scratch, pos, vel)
    np.testing.assert_array_equal(pos, start[0])
    np.testing.assert_array_equal(vel, start[1])


def test_rope_rule_is_on_block_centres_not_body_centres():
    """Body 11's middle body carries two blocks 1.2 m apart: its centre of mass is 0.6 m from
    each. Its left neighbour 1.3 m from its centre is only 0.7 m from its left block, and is
    pushed to BLOCK_SIDE from that block."""
    robot, _, scratch, _ = kit(shape="11")
    pos = at_rest("11", 11.0, 1.0)
    pos[0, 0] = pos[1, 0] - 1.3
    vel = np.zeros((6, 3))
    sync(robot, scratch, pos)
    keep_ropes(robot, scratch, pos, vel)
    left_block = pos[1, 0] - HALF
    assert left_block - pos[0, 0] == pytest.approx(BLOCK_SIDE, abs=1e-14)


# keep_orientation / restore_area -------------------------------------------------------------


def lattice(robot, pos) -> np.ndarray:
    """The lattice points (voxel corners) the bodies carry."""
    return np.array([world(pos, p, robot.corner_offset[p]) for p in range(robot.n_points)])


def outline_area(robot, pos, v: int = 0) -> float:
    quad = lattice(robot, pos)[robot.corners[v]]
    x, y = quad[:, 0], quad[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def area_gradient(robot, pos, v: int = 0) -> np.ndarray:
    """d(signed area)/d(lattice point) of voxel v's corners (4, 2), SW, SE, NE, NW."""
    quad = lattice(robot, pos)[robot.corners[v]]
    nxt, prv = np.roll(quad, -1, axis=0), np.roll(quad, 1, axis=0)
    return 0.5 * np.stack([nxt[:, 1] - prv[:, 1], prv[:, 0] - nxt[:, 0]], axis=1)


def lattice_velocity(robot, pos, vel) -> np.ndarray:
    """Velocities of the lattice points (P, 2): their bodies' translation and spin."""
    return np.array([point_velocity(pos, vel, p, world(pos, p, robot.corner_offset[p]))
                     for p in range(robot.n_points)])


def area_rate(robot, pos, vel, v: int = 0) -> float:
    """d/dt of voxel v's signed area, from its lattice points' velocities (the corner bodies'
    translation and spin)."""
    return float(np.sum(area_gradient(robot, pos, v)
                        * lattice_velocity(robot, pos, vel)[robot.corners[v]]))


def spin_rates(robot, pos, v: int = 0) -> np.ndarray:
    """d(area)/d(angular velocity) of each corner body of voxel v (4,): its lattice point's
    velocity per unit spin, along the area's gradient."""
    grad = area_gradient(robot, pos, v)
    out = []
    for p, g in zip(robot.corners[v], grad):
        r = world(pos, p, robot.corner_offset[p]) - pos[p, :2]
        out.append(float(g @ [-r[1], r[0]]))
    return np.array(out)


def expected_restore(robot, pos, v: int = 0) -> np.ndarray:
    """The mass-weighted step along the area's gradient that restores min_area to first order
    (P, 2): zero for bodies outside voxel v."""
    grad = area_gradient(robot, pos, v)
    w = robot.inv_mass[robot.corners[v]]
    step = (robot.min_area - outline_area(robot, pos, v)) / np.sum(w[:, None] * grad**2)
    out = np.zeros((robot.n_points, 2))
    out[robot.corners[v]] = step * w[:, None] * grad
    return out


def place_lattice(robot, points, angles) -> np.ndarray:
    """Body states that carry lattice points ``points`` (P, 2), turned by ``angles``."""
    pos = np.zeros((robot.n_points, 3))
    pos[:, 2] = angles
    for p in range(robot.n_points):
        pos[p, :2] = points[p] - rot(angles[p]) @ robot.corner_offset[p]
    return pos


ANGLES_1 = np.array([0.1, -0.2, 0.3, 0.05])


def squeezed(robot, top: float) -> np.ndarray:
    """The 1-voxel body with its top corners lowered to height ``top`` and sheared, its
    bodies turned (points in row order: SW, SE, NW, NE)."""
    points = np.array([[11.0, 1.0], [14.0, 1.0], [11.4, 1.0 + top], [14.4, 1.0 + top]])
    return place_lattice(robot, points, ANGLES_1)


def test_squeezed_voxel_is_restored_to_min_area_without_moving_its_centre():
    robot, _, scratch, _ = kit()
    assert robot.min_area == pytest.approx(pack_params(quiet()).min_area * VOXEL_SIDE**2)
    for deficit in (0.3, 0.05):
        pos = squeezed(robot, (robot.min_area - deficit) / VOXEL_SIDE)
        vel = np.array([[0.2, 0.5, 0.0], [0.1, 0.5, 0.0], [0.3, -1.0, 0.0],
                        [-0.2, -0.8, 0.0]])  # shrinking
        assert outline_area(robot, pos) == pytest.approx(robot.min_area - deficit, abs=1e-12)
        assert area_rate(robot, pos, vel) < 0.0
        old_pos, old_vel = pos.copy(), vel.copy()
        shift = expected_restore(robot, pos)
        sync(robot, scratch, pos)
        keep_orientation(robot, scratch, pos, vel)
        np.testing.assert_allclose(pos[:, :2] - old_pos[:, :2], shift, atol=1e-14)
        np.testing.assert_array_equal(pos[:, 2], old_pos[:, 2])
        np.testing.assert_array_equal(vel[:, 2], old_vel[:, 2])
        # Restored to first order: the rest is second order in the deficit.
        area = outline_area(robot, pos)
        assert robot.min_area - 1e-12 <= area <= robot.min_area + 0.05 * deficit
        # Centre of mass and linear momentum kept (the correction translates the bodies only,
        # so it is not balanced in angular momentum: see keep_orientation).
        np.testing.assert_allclose(moments(robot, old_pos, pos)[:2], 0.0, atol=1e-13)
        np.testing.assert_allclose(momenta(robot, old_pos, vel)[:2],
                                   momenta(robot, old_pos, old_vel)[:2], atol=1e-13)
        # The shrinking rate along the correction is removed (measured where it was decided).
        assert area_rate(robot, old_pos, vel) == pytest.approx(0.0, abs=1e-12)


def test_orientation_correction_keeps_the_centre_of_mass_for_unequal_masses():
    """Body 11's left voxel squeezed flat (its right corners on the 0.72 kg middle bodies):
    the heavier bodies move half as far per unit of gradient; centre and momentum kept."""
    robot, _, scratch, _ = kit(shape="11")
    assert robot.mass[1] == 2 * robot.mass[0]
    points = np.array([[11.0, 1.0], [14.0, 1.0], [17.0, 1.0], [11.0, 1.6], [14.3, 1.5],
                       [17.0, 4.0]])
    pos = place_lattice(robot, points, [0.0, 0.1, 0.0, -0.1, 0.2, 0.0])
    vel = np.zeros((6, 3))
    vel[3:, 1] = -1.0
    assert outline_area(robot, pos, 0) < robot.min_area < outline_area(robot, pos, 1)
    old_pos, old_vel = pos.copy(), vel.copy()
    shift = expected_restore(robot, pos, 0)
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    # Voxel 1 (corners 1, 2, 5, 4) was decided after voxel 0 moved its corners 1 and 4; its
    # area was still above the limit, so only voxel 0's correction acts.
    assert outline_area(robot, old_pos + np.pad(shift, ((0, 0), (0, 1))), 1) > robot.min_area
    np.testing.assert_allclose(pos[:, :2] - old_pos[:, :2], shift, atol=1e-14)
    assert outline_area(robot, pos, 0) >= robot.min_area - 1e-12
    np.testing.assert_allclose(moments(robot, old_pos, pos)[:2], 0.0, atol=1e-13)
    np.testing.assert_allclose(momenta(robot, old_pos, vel)[:2],
                               momenta(robot, old_pos, old_vel)[:2], atol=1e-13)
    assert area_rate(robot, old_pos, vel, 0) == pytest.approx(0.0, abs=1e-12)


def test_mirrored_voxel_is_moved_towards_positive_area():
    robot, _, scratch, _ = kit()
    points = lattice(robot, at_rest("1", 11.0, 1.0))
    points[:, 1] = 2.0 - points[:, 1]  # upside down: same lengths, area -9
    pos = place_lattice(robot, points, ANGLES_1)
    vel = np.zeros((4, 3))
    before = outline_area(robot, pos)
    old_pos = pos.copy()
    shift = expected_restore(robot, pos)
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    assert before == pytest.approx(-VOXEL_SIDE**2)
    np.testing.assert_allclose(pos[:, :2] - old_pos[:, :2], shift, atol=1e-14)
    assert outline_area(robot, pos) > before + 0.5 * VOXEL_SIDE**2
    np.testing.assert_allclose(moments(robot, old_pos, pos)[:2], 0.0, atol=1e-13)


def test_voxel_above_min_area_is_untouched():
    robot, _, scratch, _ = kit()
    pos = squeezed(robot, 1.05 * robot.min_area / VOXEL_SIDE)
    vel = np.array([[0.2, 0.5, 1.0], [0.1, 0.5, 0.0], [0.3, -1.0, 0.0], [-0.2, -0.8, -2.0]])
    start = (pos.copy(), vel.copy())
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    np.testing.assert_array_equal(pos, start[0])
    np.testing.assert_array_equal(vel, start[1])


def test_limit_is_on_the_lattice_points_of_turned_bodies():
    """The same body states pass or fail the limit depending only on the bodies' angles: the
    area is of the lattice points (centre + turned corner offset), not of the centres."""
    robot, _, scratch, _ = kit()
    pos = squeezed(robot, 1.05 * robot.min_area / VOXEL_SIDE)
    turned = pos.copy()
    turned[2:, 2] += [0.5, -0.5]  # the top bodies turned about their centres: corners down
    assert outline_area(robot, turned) < robot.min_area < outline_area(robot, pos)
    vel = np.zeros((4, 3))
    old = turned.copy()
    sync(robot, scratch, turned)
    keep_orientation(robot, scratch, turned, vel)
    np.testing.assert_allclose(turned[:, :2] - old[:, :2], expected_restore(robot, old)[:, :2],
                               atol=1e-14)


def test_growing_squeezed_voxel_keeps_its_velocity():
    robot, _, scratch, _ = kit()
    pos = squeezed(robot, 0.5)
    vel = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.1, 1.0, 0.0], [0.0, 1.0, 0.0]])
    assert area_rate(robot, pos, vel) > 0.0
    before = vel.copy()
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    assert outline_area(robot, pos) >= robot.min_area - 1e-12
    np.testing.assert_array_equal(vel, before)


def test_squeezed_voxel_whose_bodies_spin_inward_stops_shrinking():
    """The bodies do not move, but each spins the way that swings its lattice point inwards:
    the voxel shrinks through the spin alone. The correction (translations only) removes
    that rate: the lattice points' velocities, spin included, end with no shrinking along the
    area's gradient (measured where it was decided); the spins are kept."""
    robot, _, scratch, _ = kit()
    pos = squeezed(robot, (robot.min_area - 0.1) / VOXEL_SIDE)
    spin = spin_rates(robot, pos)
    assert np.all(np.abs(spin) > 0.05)  # each spin moves its point across the gradient
    vel = np.zeros((4, 3))
    vel[robot.corners[0], 2] = -2.0 * np.sign(spin)
    rate = area_rate(robot, pos, vel)
    assert rate < 0.0
    assert rate == pytest.approx(-2.0 * np.sum(np.abs(spin)), rel=1e-12)
    old_pos, old_vel = pos.copy(), vel.copy()
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    np.testing.assert_allclose(pos[:, :2] - old_pos[:, :2], expected_restore(robot, old_pos),
                               atol=1e-14)
    np.testing.assert_array_equal(pos[:, 2], old_pos[:, 2])
    np.testing.assert_array_equal(vel[:, 2], old_vel[:, 2])
    assert area_rate(robot, old_pos, vel) == pytest.approx(0.0, abs=1e-12)
    assert area_rate(robot, pos, vel) >= 0.0  # and where it ends
    # The velocity change is the mass-weighted step along the gradient that does it.
    grad = area_gradient(robot, old_pos)
    w = robot.inv_mass[robot.corners[0]]
    change = -rate / np.sum(w[:, None] * grad**2) * w[:, None] * grad
    np.testing.assert_allclose(vel[robot.corners[0], :2], change, atol=1e-13)
    np.testing.assert_allclose(momenta(robot, old_pos, vel)[:2],
                               momenta(robot, old_pos, old_vel)[:2], atol=1e-13)


def test_squeezed_voxel_whose_spin_outruns_its_shrinking_keeps_its_velocity():
    """The corner bodies move inwards but spin their lattice points outwards faster: the
    voxel grows, so only its area is restored and the velocities are kept."""
    robot, _, scratch, _ = kit()
    pos = squeezed(robot, (robot.min_area - 0.1) / VOXEL_SIDE)
    vel = np.array([[0.2, 0.5, 0.0], [0.1, 0.5, 0.0], [0.3, -1.0, 0.0], [-0.2, -0.8, 0.0]])
    moving = area_rate(robot, pos, vel)
    assert moving < 0.0
    spin = spin_rates(robot, pos)
    vel[robot.corners[0], 2] = np.sign(spin) * (2.0 * -moving / np.sum(np.abs(spin)))
    assert area_rate(robot, pos, vel) == pytest.approx(-moving, rel=1e-12)
    old_pos, old_vel = pos.copy(), vel.copy()
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    np.testing.assert_allclose(pos[:, :2] - old_pos[:, :2], expected_restore(robot, old_pos),
                               atol=1e-14)
    np.testing.assert_array_equal(vel, old_vel)


def test_collapsed_voxel_is_left_alone():
    """All four lattice points at one spot: no gradient to follow, nothing moves (no NaN)."""
    robot, _, scratch, _ = kit()
    pos = place_lattice(robot, np.tile([12.0, 2.0], (4, 1)), ANGLES_1)
    vel = np.ones((4, 3))
    start = (pos.copy(), vel.copy())
    sync(robot, scratch, pos)
    keep_orientation(robot, scratch, pos, vel)
    np.testing.assert_allclose(lattice(robot, pos), np.tile([12.0, 2.0], (4, 1)), atol=1e-14)
    np.testing.assert_array_equal(pos, start[0])
    np.testing.assert_array_equal(vel, start[1])


# set_rest_lengths / spring_length -------------------------------------------------------------


# original-system.md section 1.2: [contracted, rest, expanded] of each spring group for
# AREA_RATIO_MAX_DELTA 0.225.
ORIGINAL_RANGES = {
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
    robot, _, scratch, params = kit(shape="11", area_delta=0.225)
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


def filled(shape: str):
    return set(Body.build(shape, "none").shape.voxels)


def on_outline(point, voxels) -> bool:
    """Whether ``point`` (metres) is on the boundary of the union of the voxels: some of its
    diagonal neighbours are inside the union and some outside."""
    inside = []
    for dx in (-1e-6, 1e-6):
        for dy in (-1e-6, 1e-6):
            cell = (math.floor((point[0] + dx) / VOXEL_SIDE),
                    math.floor((point[1] + dy) / VOXEL_SIDE))
            inside.append(cell in voxels)
    return any(inside) and not all(inside)


SHAPES = ["1", "11", "111/101", "biped", "worm"]


@pytest.mark.parametrize("shape", SHAPES)
def test_geometry_has_18_springs_and_4_ropes_per_voxel_and_036_kg_blocks(shape):
    g = geometry(Body.build(shape, "none"))
    voxels = len(g.corners)
    assert len(g.springs) == 18 * voxels and len(g.ropes) == 4 * voxels
    for v in range(voxels):
        kinds = g.kinds[g.owners == v].tolist()
        assert (kinds.count(SPRING_SIDE), kinds.count(SPRING_CROSS),
                kinds.count(SPRING_CENTRAL)) == (8, 8, 2)
        assert set(g.springs[g.owners == v].ravel().tolist()) == set(g.corners[v].tolist())
    blocks = np.bincount(g.corners.ravel(), minlength=len(g.points))
    np.testing.assert_allclose(g.mass, CORNER_MASS * blocks, rtol=1e-15)
    assert g.mass.sum() == pytest.approx(4 * CORNER_MASS * voxels)
    # Each body's inertia: its blocks' own plus their parallel-axis terms, about its centre.
    single = blocks == 1
    np.testing.assert_allclose(g.inertia[single], BLOCK_INERTIA, rtol=1e-12)
    assert np.all(g.inertia[~single] > blocks[~single] * BLOCK_INERTIA)


@pytest.mark.parametrize("shape", SHAPES)
def test_spring_anchors_at_rest_have_the_rest_lengths_and_ropes_are_slack(shape):
    g = geometry(Body.build(shape, "none"))
    com = g.points * VOXEL_SIDE + g.centre
    a, b = g.springs[:, 0], g.springs[:, 1]
    lengths = np.hypot(*(com[b] + g.anchors[:, 2:] - com[a] - g.anchors[:, :2]).T)
    expected = [spring_length(int(k), 1.0) for k in g.kinds]
    np.testing.assert_allclose(lengths, expected, atol=1e-12)
    a, b = g.ropes[:, 0], g.ropes[:, 1]
    ropes = np.hypot(*(com[b] + g.rope_anchors[:, 2:] - com[a] - g.rope_anchors[:, :2]).T)
    np.testing.assert_allclose(ropes, VOXEL_SIDE - BLOCK_SIDE, atol=1e-12)


@pytest.mark.parametrize("shape", SHAPES)
def test_outline_vertices_are_block_corners_on_the_outline(shape):
    """Every outline vertex is a corner of one of its body's blocks and lies on the robot's
    outline, and every convex corner of the outline is one; the outline blocks are exactly
    the blocks with a corner on the outline."""
    voxels = filled(shape)
    g = geometry(Body.build(shape, "none"))
    com = g.points * VOXEL_SIDE + g.centre
    tips = com[g.tip_body] + g.tip_offset
    assert len(np.unique(np.round(tips, 9), axis=0)) == len(tips)
    for point, p in zip(tips, g.tip_body):
        assert on_outline(point, voxels), point
        # A block of body p spans [0, 1.2] or [-1.2, 0] from its lattice point on each axis.
        rel = point - g.points[p] * VOXEL_SIDE
        assert np.all(np.min(np.abs(rel[:, None] - [-BLOCK_SIDE, 0.0, BLOCK_SIDE]), axis=1)
                      < 1e-12), rel
    tip_set = {tuple(np.round(t, 9)) for t in tips}
    for c in g.points.astype(int):
        around = sum((c[0] + dx, c[1] + dy) in voxels for dx in (-1, 0) for dy in (-1, 0))
        if around == 1:  # a convex corner of the outline
            assert tuple(np.round(c * VOXEL_SIDE, 9)) in tip_set, c
    expected = set()
    for x, y in voxels:
        for cx, cy, ix, iy in ((x, y, 1, 1), (x + 1, y, -1, 1), (x + 1, y + 1, -1, -1),
                               (x, y + 1, 1, -1)):
            centre = np.array([cx * VOXEL_SIDE + ix * HALF, cy * VOXEL_SIDE + iy * HALF])
            if any(on_outline(centre + [sx * HALF, sy * HALF], voxels)
                   for sx in (-1, 1) for sy in (-1, 1)):
                expected.add(tuple(np.round(centre, 9)))
    blocks = com[g.block_body] + g.block_offset
    assert {tuple(np.round(b, 9)) for b in blocks} == expected
    assert len(blocks) == len(expected)


def test_one_voxel_body_has_four_bodies_with_three_outer_corners_each():
    g = geometry(Body.build("1", "none"))
    assert len(g.points) == 4
    np.testing.assert_allclose(g.mass, CORNER_MASS)
    np.testing.assert_allclose(g.inertia, BLOCK_INERTIA)
    assert np.bincount(g.tip_body).tolist() == [3, 3, 3, 3]
    assert g.block_body.tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(g.block_offset, 0.0)  # one block each, centred on its body
    for p in range(4):
        offsets = {tuple(o) for o in np.round(g.tip_offset[g.tip_body == p], 12)}
        inner = tuple(np.round(np.sign(g.centre[p]) * HALF, 12))  # towards the voxel
        corners = {(sx * HALF, sy * HALF) for sx in (-1, 1) for sy in (-1, 1)}
        assert offsets == corners - {inner}
    # At rest the block centres sit BLOCK_SIDE / 2 inside the voxel from its corners.
    np.testing.assert_allclose(np.abs(g.centre), HALF)


def test_compiled_system_places_bodies_at_their_centres_of_mass():
    robot, _, _, _ = kit(shape="11")
    system = compile_system([Body.build("11", "none")], [FLAT])
    g = geometry(Body.build("11", "none"))
    pos = system.initial_pos[0, : len(g.points)]
    np.testing.assert_allclose(pos + system.corner_offset[0, : len(g.points)] - pos[0]
                               - system.corner_offset[0, 0], g.points * VOXEL_SIDE, atol=1e-12)
    np.testing.assert_allclose(1.0 / robot.inv_mass, g.mass)
    np.testing.assert_allclose(1.0 / robot.inv_inertia, g.inertia)
    assert robot.n_tips == len(g.tip_body) and robot.n_blocks == len(g.block_body)
