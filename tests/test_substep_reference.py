"""The compiled substep matches the NumPy oracle of tests/reference/substep.py.

States: the worm and the biped at rest on flat ground (their bottom block faces on it), and
the same bodies in random states on hilly terrain (and one steppy terrain): draped over the
ground and 2 cm into it, every body moved and turned a little, random velocities and
actuations, so that some block corners are under the ground and some terrain vertices inside
outline blocks; in each, one rope limit violated, one voxel squeezed below its smallest area
and still collapsing, one outline vertex under the ground right next to a terrain vertex (the
nearest-point search) and one just above the ground (touching, not pushed). All under the
default settings, whatever they are.

Cases: the worm built so that one branch of the model must act, under explicit settings
(so that they do not depend on the defaults): one block corner hitting flat ground, sticking,
sliding at the Coulomb limit (once with the sliding reversed by the impulse), bouncing; a
block with one corner approaching the ground and one leaving it; a voxel collapsing only
through its bodies' spin.

The kernel runs through ``advance`` (with one substep for the single-substep comparisons):
it is the episode's entry point, and takes the bodies' rotations afresh before its substeps,
which keep them up to date (so the whole control step checks that they do).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.physics import advance, set_rest_lengths
from somite.sim.robot import ground_view, new_scratch, robot_view
from somite.sim.system import PLACEMENT_GAP, compile_system
from somite.sim.terrain import flat, hilly, steppy

from .conftest import quiet
from .reference import substep as reference

CONFIG = quiet()
TOLERANCE = 1e-12


def kernel_and_model(shape: str, terrain, config=CONFIG):
    """The kernel's (robot, ground, params), the oracle's model and the bodies' starting
    state (P, 3): centres of mass as placed, unturned."""
    system = compile_system([Body.build(shape, "none")], [terrain])
    params = pack_params(config)
    robot = robot_view(system, 0, params)
    pos = np.zeros((robot.n_points, 3))
    pos[:, :2] = system.initial_pos[0, : robot.n_points]
    return (robot, ground_view(system, 0), params), reference.model(system, 0, config), pos


@cache
def ground_of(name: str):
    """The terrain of state ``name`` (one object per state, as a batch would share it)."""
    _, kind, seed = name.split("-")
    if kind == "rest":
        return flat()
    seed = int(seed)
    if kind == "steppy":  # steps of ~3 m, risers 5 cm wide
        return steppy(0.5, 3.0, 300 + seed)
    return hilly(0.5, 2.0, 100 + seed) if seed % 2 else hilly(1.0, 3.0, 200 + seed)


def at_rest(shape):
    kernel, model, pos = kernel_and_model(shape, ground_of(f"{shape}-rest-flat"))
    pos[:, 1] -= PLACEMENT_GAP  # the bottom block faces on the ground
    return kernel, model, pos, np.zeros_like(pos), np.zeros(len(model.corners))


def world(model, pos, p, offset):
    return pos[p, :2] + reference.lever(pos, p, offset)


def squeeze(model, pos):
    """The last voxel (top right) squeezed to 0.2 of its size along its diagonal: its NE body
    moved towards its SW corner (no rope joins those two), area about 0.2 x 9 m^2. The NE
    body and the unit vector from its corner to SW's."""
    sw, _, ne, _ = model.corners[-1]
    diagonal = (world(model, pos, sw, model.corner_offset[sw])
                - world(model, pos, ne, model.corner_offset[ne]))
    pos[ne, :2] += 0.8 * diagonal
    return ne, diagonal / np.hypot(*diagonal)


def random_state(name):
    """See the module docstring. The deliberate violations come last, each moving one body
    that the others leave alone."""
    shape, _, seed = name.split("-")
    rng = np.random.default_rng(int(seed))
    kernel, model, pos = kernel_and_model(shape, ground_of(name))
    xs, ys = model.xs, model.ys
    lattice = pos[:, :2] + model.corner_offset  # unturned: the lattice at rest
    top = np.flatnonzero(lattice[:, 1] == lattice[:, 1].max())
    tip_y = pos[model.tip_body, 1] + model.tip_offset[:, 1]
    bottom_tips = np.flatnonzero(np.isclose(tip_y, tip_y.min()))  # on the bottom faces
    # Somewhere along the terrain, each lattice column following the ground under it, the
    # bottom row 2 cm into it; then every body moved ~3 cm and turned ~3 degrees.
    pos[:, 0] += rng.uniform(5.0, 30.0)
    lattice[:, 0] = pos[:, 0] + model.corner_offset[:, 0]
    pos[:, 1] += np.interp(lattice[:, 0], xs, ys) - lattice[:, 1].min() - 0.02
    pos[:, :2] += rng.normal(0.0, 0.03, (len(pos), 2))
    pos[:, 2] = rng.normal(0.0, 0.05, len(pos))
    vel = np.column_stack([rng.normal(0.0, 1.0, (len(pos), 2)), rng.normal(0.0, 1.0, len(pos))])
    actuation = rng.uniform(-1.0, 1.0, len(model.corners))
    # The last voxel (top right) squeezed (``squeeze``), and still collapsing: its NE body
    # moves on towards SW, faster than the springs, stretched by metres, give back in the
    # substep.
    ne, towards = squeeze(model, pos)
    closing = 10.0  # [m/s]
    # The NE body's speed towards SW such that it still closes at 10 m/s after the substep's
    # springs (its velocity then is affine in its velocity now: the oracle's first step
    # gives the two coefficients).
    rest = reference.rest_lengths(model, actuation)
    after = []
    for speed in (0.0, 1.0):
        vel[ne, :2] = speed * towards
        p, v = pos.copy(), vel.copy()
        reference._springs_gravity_drag(model, p, v, rest)
        after.append(v[ne, :2] @ towards)
    vel[ne, :2] = (closing - after[0]) / (after[1] - after[0]) * towards
    # One rope of the top row, away from that voxel: its block centres 1.1 m apart (1.8 m
    # at rest).
    ropes = [y for y, (a, b) in enumerate(model.rope_ends)
             if a in top and b in top and ne not in (a, b)]
    y = ropes[int(rng.integers(len(ropes)))]
    a, b = model.rope_ends[y]
    apart = world(model, pos, b, model.rope_anchor[y, 2:]) - world(model, pos, a,
                                                                  model.rope_anchor[y, :2])
    length = np.hypot(*apart)
    pos[b, :2] -= (length - 1.1) * apart / length
    # The outline vertex at the bottom nearest (in x) to a terrain vertex: its body moved so
    # that it is 3 cm right of the terrain vertex and 10 cm under the ground (deeper than it
    # is far from the segment's end).
    tips = [f for f in bottom_tips if model.tip_body[f] not in (ne, a, b)]
    points = np.array([world(model, pos, model.tip_body[f], model.tip_offset[f]) for f in tips])
    inner = xs[1:-1]
    far = np.abs(points[:, 0][:, None] - inner[None, :])
    f, k = np.unravel_index(np.argmin(far), far.shape)
    x = inner[k] + 0.03
    near = model.tip_body[tips[f]]
    pos[near, :2] += [x - points[f, 0], np.interp(x, xs, ys) - 0.1 - points[f, 1]]
    # Another one, of another body, 5 mm above the ground, its body at rest (so that it moves
    # less than 1 mm in the substep): touching the ground, not under it.
    f = next(f for f in rng.permutation(tips) if model.tip_body[f] != near)
    p = model.tip_body[f]
    x, height = world(model, pos, p, model.tip_offset[f])
    pos[p, 1] += np.interp(x, xs, ys) + 0.005 - height
    vel[p] = 0.0
    return kernel, model, pos, vel, actuation


NAMES = [f"{shape}-{kind}" for shape in ("worm", "biped")
         for kind in ("rest-flat", "hilly-0", "hilly-1", "hilly-2", "hilly-3", "steppy-4")]


@cache
def state(name: str):
    """(kernel, model, pos, vel, actuation) of state ``name``."""
    if name.endswith("rest-flat"):
        return at_rest(name.split("-")[0])
    return random_state(name)


def worm_on_flat(config, lower):
    """The worm on flat ground, its bottom block faces ``lower`` [m] under it."""
    kernel, model, pos = kernel_and_model("worm", ground_of("worm-rest-flat"), config)
    pos[:, 1] -= PLACEMENT_GAP + lower
    return kernel, model, pos


TURN = np.radians(10.0)  # how far corner_case turns the worm [rad]


def corner_case(velocity, turn=TURN, **settings):
    """The worm on flat ground, 20 m from the wall, turned rigidly by ``turn`` about the left
    corner of its bottom face, which is 1 cm under the ground; every body moving at
    ``velocity`` (m/s, no spin): the springs at rest, one contact (that corner, its body a
    single block)."""
    kernel, model, pos = worm_on_flat(quiet(**settings), 0.0)
    pos[:, 0] += 20.0
    tips = np.array([world(model, pos, p, o) for p, o in zip(model.tip_body, model.tip_offset)])
    pivot = tips[np.lexsort((tips[:, 0], tips[:, 1]))[0]]  # lowest, then leftmost
    pos[:, :2] = pivot + (pos[:, :2] - pivot) @ reference.rotation(turn).T
    pos[:, 2] = turn
    pos[:, 1] -= 0.01
    vel = np.zeros_like(pos)
    vel[:, :2] = velocity
    return kernel, model, pos, vel, np.zeros(len(model.corners))


def rocking_case():
    """The worm on flat ground, its bottom faces 2 cm under it, turning rigidly at 1 rad/s
    about the middle of its leftmost bottom face: that face's left corner approaches the
    ground, its right corner and all the others leave it (its body's impulse is the one
    approaching contact's, its push the mean of two)."""
    kernel, model, pos = worm_on_flat(quiet(friction=1.0, restitution=0.0), 0.02)
    left = model.tip_body[np.argmin(pos[model.tip_body, 0] + model.tip_offset[:, 0])]
    centre = pos[left, :2] + [0.0, model.tip_offset[:, 1].min()]
    spin = 1.0
    vel = np.column_stack([-spin * (pos[:, 1] - centre[1]), spin * (pos[:, 0] - centre[0]),
                           np.full(len(pos), spin)])
    return kernel, model, pos, vel, np.zeros(len(model.corners))


def area_rate(model, pos, vel, quad):
    """Rate [m^2/s] of the signed area of the voxel of bodies ``quad``: its lattice points'
    velocities (the bodies' motion and spin), by central differences of the shoelace area."""
    points = reference.lattice_points(model, pos, quad)
    moving = np.array([reference.point_velocity(vel[p], reference.lever(pos, p,
                                                                        model.corner_offset[p]))
                       for p in quad])
    h = 1e-6
    return (reference.signed_area(points + h * moving)
            - reference.signed_area(points - h * moving)) / (2.0 * h)


def spinning_case():
    """The worm as placed (1 m above flat ground), its last voxel squeezed (``squeeze``) and
    opening at 0.3 m/s, but collapsing faster through its bodies' spins (10 rad/s each, the
    way that closes it); springs too weak to matter."""
    kernel, model, pos = kernel_and_model("worm", ground_of("worm-rest-flat"),
                                          quiet(spring_hz=0.2, damping_ratio=0.0))
    ne, towards = squeeze(model, pos)
    vel = np.zeros_like(pos)
    vel[ne, :2] = -0.3 * towards
    quad = model.corners[-1]
    for p in quad:
        spun = np.zeros_like(vel)
        spun[p, 2] = 1.0
        vel[p, 2] = -10.0 * np.sign(area_rate(model, pos, spun, quad))
    return kernel, model, pos, vel, np.zeros(len(model.corners))


CASES = {  # name: (state, branches of the model that it must exercise)
    "stick": (lambda: corner_case((0.3, -0.5), friction=1.0), ("no_bounce", "stick")),
    "slide": (lambda: corner_case((3.0, -0.5), friction=0.5), ("slide",)),
    # Sliding a little forwards, but the normal impulse, turning the block, reverses that:
    # it slides backwards, friction against that sliding.
    "slide-reversed": (lambda: corner_case((0.05, -0.5), friction=0.3), ("slide",)),
    "bounce": (lambda: corner_case((0.0, -3.0), friction=1.0, restitution=0.5), ("bounce",)),
    "rocking": (rocking_case, ("separating", "stick")),
    "spinning": (spinning_case, ("orientation_spin",)),
}


@cache
def case(name: str):
    """(kernel, model, pos, vel, actuation) of case ``name``."""
    return CASES[name][0]()


def run_kernel(kernel, pos, vel, actuation, substeps=1):
    """``set_rest_lengths``, then ``substeps`` compiled substeps (``advance``, the episode's
    entry point: it takes the bodies' rotations afresh, then runs ``substep``), on copies of
    the state and a fresh scratch: (pos, vel, contact flags, rest lengths)."""
    robot, ground, params = kernel
    scratch = new_scratch(robot)
    pos, vel = pos.copy(), vel.copy()
    set_rest_lengths(robot.n_springs, robot.kind, robot.owner, actuation, params.contract,
                     params.expand, scratch.rest)
    advance(robot, ground, scratch, pos, vel, params, substeps)
    return pos, vel, scratch.contact.copy(), scratch.rest.copy()


def run_oracle(model, pos, vel, actuation, substeps=1, events=None):
    rest = reference.rest_lengths(model, actuation)
    for _ in range(substeps):
        pos, vel, contact = reference.substep(model, pos, vel, rest, events)
    return pos, vel, contact, rest


def assert_same(got, expected, tolerance=TOLERANCE):
    for name, g, e in zip(("pos", "vel"), got[:2], expected[:2]):
        np.testing.assert_allclose(g, e, rtol=0, atol=tolerance, err_msg=name)
    np.testing.assert_array_equal(got[2], expected[2], err_msg="contact")
    np.testing.assert_allclose(got[3], expected[3], rtol=0, atol=TOLERANCE, err_msg="rest")


@pytest.mark.parametrize("name", NAMES)
def test_substep_matches_the_numpy_reference(name):
    kernel, model, pos, vel, actuation = state(name)
    expected = run_oracle(model, pos, vel, actuation)
    assert_same(run_kernel(kernel, pos, vel, actuation), expected)
    assert np.abs(expected[0] - pos).max() > 1e-5  # something happened


@pytest.mark.parametrize("name", CASES)
def test_constructed_cases_match_the_reference(name):
    """Each case exercises its branches (in the oracle), and the kernel agrees with it."""
    kernel, model, pos, vel, actuation = case(name)
    events = reference.Events()
    expected = run_oracle(model, pos, vel, actuation, events=events)
    for branch in CASES[name][1]:
        assert events.counts.get(branch, 0) > 0, (name, branch, events.counts)
    assert_same(run_kernel(kernel, pos, vel, actuation), expected)


def test_the_states_exercise_every_branch_of_the_model():
    """So that the comparisons above cannot pass by comparing free falls only: over all
    states and cases, every branch acts; in each random state, each deliberate violation
    acts.
"""
    total = reference.Events()
    for name in NAMES + list(CASES):
        _, model, pos, vel, actuation = state(name) if name in NAMES else case(name)
        events = reference.Events()
        run_oracle(model, pos, vel, actuation, events=events)
        if name in NAMES and "rest" not in name:
            for branch in ("rope", "orientation", "orientation_shrinking", "tip_nearest",
                           "tip_straight"):
                assert events.counts.get(branch, 0) > 0, (name, branch, events.counts)
        for branch, count in events.counts.items():
            total.counts[branch] = total.counts.get(branch, 0) + count
    for branch in ("tip_straight", "tip_nearest", "tip_touching", "vertex_inside", "rope",
                   "rope_closing", "orientation", "orientation_shrinking", "orientation_spin",
                   "separating", "bounce", "no_bounce", "stick", "slide"):
        assert total.counts.get(branch, 0) > 0, (branch, total.counts)
    assert "slide_reversed" not in total.counts


@pytest.mark.parametrize("name", ["worm-hilly-0", "biped-hilly-1", "biped-steppy-4"])
def test_a_whole_control_step_matches_the_reference(name):
    """``advance`` over a control step's substeps (the kernel's rotations and terrain
    segments carried from one substep to the next) against the oracle's substeps in a
    row."""
    kernel, model, pos, vel, actuation = state(name)
    expected = run_oracle(model, pos, vel, actuation, CONFIG.substeps)
    assert_same(run_kernel(kernel, pos, vel, actuation, CONFIG.substeps), expected, 1e-10)


DEFAULT = SimConfig()
SETTINGS = [  # each far from its default, whatever that is
    dict(spring_hz=0.6 * DEFAULT.spring_hz), dict(damping_ratio=0.3 * DEFAULT.damping_ratio),
    dict(friction=0.3 * DEFAULT.friction),
    dict(restitution=DEFAULT.restitution + (0.5 if DEFAULT.restitution < 0.5 else -0.5)),
    dict(drag=DEFAULT.drag + 3.0), dict(gravity=0.3 * DEFAULT.gravity),
    dict(area_delta=0.5 * DEFAULT.area_delta),
    dict(min_area_ratio=DEFAULT.min_area_ratio + (0.3 if DEFAULT.min_area_ratio < 0.5 else -0.3)),
    dict(substeps=DEFAULT.substeps + 1)]


@pytest.mark.parametrize("options", SETTINGS, ids=lambda o: next(iter(o)))
def test_the_reference_follows_the_settings(options):
    """With one setting changed, kernel and oracle still agree, and differ from the default
    setting's result: both read that setting, and the state is one where it matters."""
    name = "worm-hilly-3"
    _, model, pos, vel, actuation = state(name)
    kernel, changed, _ = kernel_and_model("worm", ground_of(name), quiet(**options))
    expected = run_oracle(changed, pos, vel, actuation)
    assert_same(run_kernel(kernel, pos, vel, actuation), expected)
    default = run_oracle(model, pos, vel, actuation)
    assert max(np.abs(default[k] - expected[k]).max() for k in (0, 1)) > 1e-6


def test_a_sliding_contact_never_pulls_into_the_ground():
    """When the sticking impulse is refused, friction at its limit the way that impulse
    pushed (s = sign of its j_t) never makes the normal row's slope K_nn + s friction K_nt
    non-positive (then the point would have stuck: K's determinant is
    (1/m) (1/m + |r|^2 / I) > 0), and it opposes the sliding that the impulse leaves.
    Checked on random bodies, levers, contacts and velocities."""
    rng = np.random.default_rng(0)
    n = 200_000
    inv_mass = 1.0 / rng.uniform(0.1, 5.0, n)
    inv_inertia = inv_mass / rng.uniform(0.05, 2.0, n) ** 2
    rn, rt = rng.uniform(-3.0, 3.0, (2, n))  # the lever across the normal, along it
    mu = rng.uniform(0.0, 5.0, n)
    want_n = rng.uniform(1e-3, 5.0, n)
    vt = rng.normal(0.0, 3.0, n) * rng.choice([0.0, 1e-3, 1.0], n)
    k_nn = inv_mass + rn * rn * inv_inertia
    k_tt = inv_mass + rt * rt * inv_inertia
    k_nt = rn * rt * inv_inertia
    det = k_nn * k_tt - k_nt * k_nt
    jn = (k_tt * want_n + k_nt * vt) / det
    jt = (-k_nn * vt - k_nt * want_n) / det
    slides = ~((jn >= 0.0) & (np.abs(jt) <= mu * jn))
    assert slides.sum() > 10_000
    side = np.where(jt > 0.0, 1.0, -1.0)
    slope = k_nn + side * mu * k_nt
    assert (slope[slides] > 0.0).all()
    jn_slide = want_n / slope
    after = vt + k_nt * jn_slide + k_tt * side * mu * jn_slide
    assert (side * after <= 1e-12 * np.abs(vt).max())[slides].all()
