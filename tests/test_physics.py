"""Physics invariants of the simulator (issue: the soft-robot simulator)."""

from __future__ import annotations

import numpy as np
import pytest

from somite.brain.controllers import Sine, Table, Zero
from somite.sim.body import Body
from somite.sim.config import CONTROL_HZ, P_DT, pack_params
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.locomotion import simulate

from .conftest import quiet, voxel_geometry

FLAT = parse_terrain("flat")


def test_worm_at_rest_settles(worm):
    config = quiet(duration=10.0)
    [outcome], trace = simulate([worm], [FLAT], [Zero()], config, record=True)
    after = int(5 * CONTROL_HZ)
    com = trace.com[0, after:]
    speed = np.linalg.norm(np.diff(com, axis=0), axis=1) * CONTROL_HZ
    assert speed.max() < 0.01
    for k in range(after, config.n_steps + 1, 60):
        _, area = voxel_geometry(worm, trace.pos[0, k])
        assert np.all(np.abs(area - 1.0) < 0.02)
    assert outcome.finite and abs(outcome.velocity) < 0.01


def test_dropped_robot_falls_with_g(biped):
    """Until a corner touches, the centre of mass follows semi-implicit Euler under g exactly
    (no drag), and the analytic fall with linear drag c, g/c (t - (1 - exp(-c t)) / c), to
    within 1% with the default drag."""
    for drag, tolerance in ((0.0, 1e-9), (0.1, 0.01)):
        config = quiet(duration=1.0, drag=drag)
        _, trace = simulate([biped], [FLAT], [Zero()], config, record=True)
        touching = trace.contact[0].any(axis=1)
        first_touch = int(np.argmax(touching))
        assert 10 < first_touch < 40  # a 1 m drop takes ~0.45 s
        dt = pack_params(config)[P_DT]
        y0 = trace.com[0, 0, 1]
        for k in range(1, first_touch):
            n = k * config.substeps
            if drag == 0.0:
                expected = y0 - config.gravity * dt * dt * n * (n + 1) / 2
                assert abs(trace.com[0, k, 1] - expected) < tolerance
            elif k >= 20:  # from there on the O(dt) error of the integrator is under 0.7%
                t = k / CONTROL_HZ
                fallen = y0 - trace.com[0, k, 1]
                expected = config.gravity / drag * (t - (1 - np.exp(-drag * t)) / drag)
                assert abs(fallen - expected) <= tolerance * expected
        assert np.all(trace.com[0, : first_touch - 1, 0] == trace.com[0, 0, 0])


@pytest.mark.slow
def test_random_bang_bang_never_inverts_or_blows_up(worm, biped):
    """1000 random bang-bang controllers (switching up to 30 Hz), 30 s on hilly terrain."""
    rng = np.random.default_rng(1)
    for body, count in ((worm, 500), (biped, 500)):
        voxels = body.shape.n_voxels
        tables = [Table(rng.choice([-1.0, 1.0], size=(int(rng.integers(2, 121)), voxels)))
                  for _ in range(count)]
        terrains = [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, count)]
        outcomes, trace = simulate([body] * count, terrains, tables, quiet(), seeds=0)
        assert all(o.finite for o in outcomes)
        assert np.all(np.isfinite(trace.com))
        assert trace.min_area.min() > 0.2  # never inverted, never collapsed


def _distance(body: Body, controller, terrain=FLAT, duration=10.0) -> float:
    config = quiet(duration=duration, start_gap=100.0)
    [outcome], _ = simulate([body], [terrain], [controller], config)
    return outcome.distance


def test_travelling_waves_move_the_worm_both_ways(worm):
    forward = _distance(worm, Sine(1.0, 1.0, -1.0))
    backward = _distance(worm, Sine(1.0, 1.0, 1.0))
    uniform = _distance(worm, Sine(1.0, 1.0, 0.0))
    assert forward > 2.0
    assert backward < -2.0
    assert 0.8 < -backward / forward < 1.25
    assert abs(uniform) < 0.1 * forward


def test_uphill_gives_less_headway(worm):
    gait = Sine(1.0, 1.0, -1.0)
    config = quiet(duration=10.0)
    [flat], _ = simulate([worm], [FLAT], [gait], config)
    [uphill], _ = simulate([worm], [parse_terrain("uphill-20")], [gait], config)
    assert uphill.distance < 0.5 * flat.distance


def test_mirrored_body_and_actuation_mirror_the_motion():
    """An L-shaped body and its mirror image, driven by mirrored actuation, move by the same
    distance in opposite directions (the physics has no preferred side)."""
    left = Body.build("10/11", "none")
    right = Body.build("01/11", "none")
    steps = np.arange(40)[:, None]
    columns = np.array([x for x, _ in left.shape.voxels])[None, :]
    rows = np.sin(2 * np.pi * steps / 40 - columns)
    # Voxel (x, y) of the left body is voxel (1 - x, y) of the right one.
    mirror = [right.shape.index(1 - x, y) for x, y in left.shape.voxels]
    mirrored = np.empty_like(rows)
    mirrored[:, mirror] = rows
    config = quiet(duration=6.0, start_gap=200.0)
    outcomes, _ = simulate([left, right], [FLAT, FLAT], [Table(rows), Table(mirrored)], config)
    assert abs(outcomes[0].distance) > 0.3
    assert abs(outcomes[0].distance + outcomes[1].distance) < 0.02 * abs(outcomes[0].distance)
