"""The compiled substep matches the NumPy oracle of tests/reference/substep.py (issue 8).

States: the worm and the biped at rest on flat ground (bottom corners on it), and the same
bodies in random states on hilly terrain: corners moved, random velocities and actuations,
lowered so that some corners are under the ground and terrain peaks poke into bottom sides,
one voxel turned inside out and one side squeezed below its length limit.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from somite.sim.body import Body
from somite.sim.config import pack_params
from somite.sim.physics import CONTACT_TOLERANCE, enforce_min_lengths, set_rest_lengths, substep
from somite.sim.robot import ground_view, new_scratch, robot_view
from somite.sim.system import PLACEMENT_GAP, compile_system
from somite.sim.terrain import flat, hilly

from .conftest import quiet
from .reference import substep as reference

CONFIG = quiet(contact_radius=0.0)  # point corners: the states place peaks exactly
TOLERANCE = 1e-12


def kernel_and_model(shape: str, terrain, config=CONFIG):
    """The kernel's (robot, ground, scratch, params), the oracle's model and the robot's
    starting positions."""
    system = compile_system([Body.build(shape, "none")], [terrain])
    params = pack_params(config)
    robot = robot_view(system, 0, params)
    kernel = (robot, ground_view(system, 0), new_scratch(robot), params)
    start = system.initial_pos[0, : robot.n_points].copy()
    return kernel, reference.model(system, 0, config), start


def at_rest(shape):
    kernel, model, pos = kernel_and_model(shape, ground_of(f"{shape}-rest-flat"))
    pos[:, 1] -= PLACEMENT_GAP  # the bottom corners on the ground
    return kernel, model, pos, np.zeros_like(pos), np.zeros(len(model.corners))


def hills(seed: int):
    return hilly(0.5, 2.0, 100 + seed) if seed % 2 else hilly(1.0, 3.0, 200 + seed)


@cache
def ground_of(name: str):
    """The terrain of state ``name`` (one object per state, as a batch would share it)."""
    kind = name.split("-", 1)[1]
    return flat() if kind == "rest-flat" else hills(int(kind.split("-")[1]))


def peak_depth(vertex, pa, pb) -> tuple[float, float, float]:
    """Where a terrain vertex lies relative to side pa -> pb: its fraction along the side,
    its depth behind it, and how fast the depth grows as the side moves down."""
    side = pb - pa
    outward = np.array([side[1], -side[0]]) / np.hypot(*side)
    lam = (vertex - pa) @ side / (side @ side)
    return lam, -(vertex - pa) @ outward, -outward[1]


def random_state(shape, seed):
    """Corners moved ~0.1 m, velocities ~1 m/s, any actuation, on a hilly terrain; one voxel
    turned inside out (its top corners swapped: no length limit sees it) and one outer side
    squeezed below its length limit. One bottom side sits on a crest of the terrain, the
    crest 0.1 m deeper than max_peak_depth into it (even seeds) or just within the tolerated
    depth (odd seeds); corners of other sides may end up under the ground."""
    rng = np.random.default_rng(seed)
    kernel, model, pos = kernel_and_model(shape, ground_of(f"{shape}-random-{seed}"))
    bottom = np.flatnonzero(pos[:, 1] == pos[:, 1].min())
    sides = [(a, b) for a, b in model.boundary if a in bottom and b in bottom]
    a, b = sides[int(rng.integers(len(sides)))]
    pos += rng.normal(0.0, 0.1, pos.shape)
    vel = rng.normal(0.0, 1.0, pos.shape)
    actuation = rng.uniform(-1.0, 1.0, len(model.corners))
    xs, ys = model.xs, model.ys
    crest = next(k for k in range(2, len(xs) - 2)
                 if xs[k] > pos[:, 0].max() and ys[k - 1] < ys[k] > ys[k + 1])
    pos[:, 0] += xs[crest] - 0.5 * (pos[a, 0] + pos[b, 0]) + rng.uniform(-0.5, 0.5)
    _, _, ne, nw = model.corners[-1]
    pos[[ne, nw]] = pos[[nw, ne]]
    c, d = model.boundary[int(rng.integers(len(model.boundary)))]
    middle = 0.5 * (pos[c] + pos[d])
    pos[c] = middle + 0.4 * (pos[c] - middle)
    pos[d] = middle + 0.4 * (pos[d] - middle)
    # Lower the robot until the crest is at the target depth when the side contacts act
    # (the springs and the ground contacts of the same substep act first).
    target = model.peak_depth + (0.1 if seed % 2 == 0 else -0.5 * CONTACT_TOLERANCE)
    rest = reference.rest_lengths(model, actuation)
    for _ in range(6):
        moved, _, _ = reference.before_sides(model, pos, vel, rest)
        _, depth, rate = peak_depth(np.array([xs[crest], ys[crest]]), moved[a], moved[b])
        pos[:, 1] -= (target - depth) / rate
    return kernel, model, pos, vel, actuation


NAMES = [f"{shape}-{kind}" for shape in ("worm", "biped")
         for kind in ("rest-flat", "random-0", "random-1", "random-2", "random-3")]


@cache
def state(name: str):
    """(kernel, model, pos, vel, actuation) of state ``name``."""
    shape, kind = name.split("-", 1)
    if kind == "rest-flat":
        return at_rest(shape)
    return random_state(shape, int(kind.split("-")[1]))


def run_kernel(kernel, pos, vel, actuation, substeps=1):
    robot, ground, scratch, params = kernel
    pos, vel = pos.copy(), vel.copy()
    set_rest_lengths(robot.n_voxels, robot.n_springs, robot.owners, robot.rest0, actuation,
                     params.contract, params.expand, scratch.factor, scratch.rest)
    for _ in range(substeps):
        substep(robot, ground, scratch, pos, vel, params)
    return pos, vel, scratch.contact.copy(), scratch.rest.copy()


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("radius", [None, 0.4])
def test_substep_matches_the_numpy_reference(name, radius):
    """With point corners, and with corners rounded to discs of 0.4 m."""
    kernel, model, pos, vel, actuation = state(name)
    if radius is not None:
        kernel, model, _ = kernel_and_model(name.split("-")[0], ground_of(name),
                                            quiet(contact_radius=radius))
    rest = reference.rest_lengths(model, actuation)
    expected = reference.substep(model, pos, vel, rest)
    got = run_kernel(kernel, pos, vel, actuation)
    np.testing.assert_allclose(got[3], rest, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(got[0], expected[0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(got[1], expected[1], rtol=0, atol=TOLERANCE)
    np.testing.assert_array_equal(got[2], expected[2])
    assert not np.array_equal(got[0], pos)


def test_the_states_exercise_every_branch_of_the_model():
    """So that the comparisons above cannot pass by comparing free falls only."""
    events = reference.Events()
    for name in NAMES:
        _, model, pos, vel, actuation = state(name)
        _, round_model, _ = kernel_and_model(name.split("-")[0], ground_of(name),
                                             quiet(contact_radius=0.4))
        for m in (model, round_model):
            reference.substep(m, pos, vel, reference.rest_lengths(m, actuation), events)
    for branch in ("min_length", "orientation", "ground", "ground_disc", "ground_impact",
                   "ground_slide", "side_touch", "side_push"):
        assert events.counts.get(branch, 0) > 0, (branch, events.counts)


@pytest.mark.parametrize("name", ["worm-random-0", "biped-random-1"])
def test_a_whole_control_step_matches_the_reference(name):
    """Eight substeps in a row (the terrain segments remembered between them), then the
    end-of-step length limit, as the episode loop runs them."""
    kernel, model, pos, vel, actuation = state(name)
    robot, _, _, _ = kernel
    rest = reference.rest_lengths(model, actuation)
    expected_pos, expected_vel = pos, vel
    for _ in range(CONFIG.substeps):
        expected_pos, expected_vel, expected_contact = reference.substep(
            model, expected_pos, expected_vel, rest)
    reference.enforce_min_lengths(model, expected_pos, expected_vel)
    got_pos, got_vel, contact, _ = run_kernel(kernel, pos, vel, actuation, CONFIG.substeps)
    enforce_min_lengths(robot.n_springs, robot.ends, robot.min_length, robot.inv_mass, got_pos,
                        got_vel)
    np.testing.assert_allclose(got_pos, expected_pos, rtol=0, atol=1e-10)
    np.testing.assert_allclose(got_vel, expected_vel, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(contact, expected_contact)


def test_the_reference_follows_the_settings():
    """The oracle reads stiffness, damping, friction and limits from SimConfig: with other
    settings both sides still agree, and differ from the defaults."""
    config = quiet(spring_hz=5.0, damping_ratio=0.6, friction=0.5, drag=0.3,
                   diagonal_stiffness=0.5, max_peak_depth=0.1, min_area_ratio=0.5, substeps=16,
                   contact_radius=0.3)
    _, model, pos, vel, actuation = state("biped-random-2")
    kernel, changed, _ = kernel_and_model("biped", ground_of("biped-random-2"), config)
    expected = reference.substep(changed, pos, vel, reference.rest_lengths(changed, actuation))
    got = run_kernel(kernel, pos, vel, actuation)
    np.testing.assert_allclose(got[0], expected[0], rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(got[1], expected[1], rtol=0, atol=TOLERANCE)
    np.testing.assert_array_equal(got[2], expected[2])
    default = reference.substep(model, pos, vel, reference.rest_lengths(model, actuation))
    assert np.abs(default[1] - expected[1]).max() > 1e-3
