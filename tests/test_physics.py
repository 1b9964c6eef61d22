"""Physics invariants of the simulator (issue: the soft-robot simulator)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.brain.controllers import Sine, Table, Zero
from somite.sim.body import Body
from somite.sim.config import CONTROL_HZ, pack_params
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.locomotion import simulate_batch

from .conftest import quiet, voxel_geometry

FLAT = parse_terrain("flat")


def test_worm_at_rest_settles(worm):
    config = quiet(duration=10.0)
    [outcome], trace = simulate_batch([worm], [FLAT], [Zero()], config, record=True)
    after = int(5 * CONTROL_HZ)
    com = trace.com[0, after:]
    speed = np.linalg.norm(np.diff(com, axis=0), axis=1) * CONTROL_HZ
    assert speed.max() < 0.01
    for k in range(after, config.n_steps + 1, 60):
        _, area = voxel_geometry(worm, trace.pos[0, k])
        assert np.all(np.abs(area - 1.0) < 0.02)
    assert outcome.finite and abs(outcome.velocity) < 0.01


def test_dropped_robot_falls_with_g(biped):
    """Until a block touches, every block follows dyn4j's integrator exactly: the velocity
    gains -g dt, then is damped by the factor 1 - c dt, then moves the block; and it does not
    drift sideways or turn."""
    for drag in (0.0, 0.1):
        config = quiet(duration=1.0, drag=drag)
        _, trace = simulate_batch([biped], [FLAT], [Zero()], config, record=True)
        touching = trace.contact[0].any(axis=1)
        first_touch = int(np.argmax(touching))
        assert 10 < first_touch < 40  # a 1 m drop takes ~0.45 s
        dt = pack_params(config).dt
        y = trace.com[0, 0, 1]
        v = 0.0
        for k in range(1, first_touch):
            v = (v - config.gravity * dt) * (1 - drag * dt)
            y += v * dt
            assert trace.com[0, k, 1] == pytest.approx(y, abs=1e-9)
        assert np.all(trace.com[0, : first_touch - 1, 0] == trace.com[0, 0, 0])


@pytest.mark.slow
def test_random_bang_bang_never_inverts_or_blows_up(worm, biped):
    """240 random bang-bang controllers (switching up to 30 Hz), 30 s on hilly terrain."""
    rng = np.random.default_rng(1)
    for body, count in ((worm, 120), (biped, 120)):
        voxels = body.shape.n_voxels
        tables = [Table(rng.choice([-1.0, 1.0], size=(int(rng.integers(2, 121)), voxels)))
                  for _ in range(count)]
        terrains = [hilly(1.0, 10.0, int(s)) for s in rng.integers(0, 10000, count)]
        outcomes, trace = simulate_batch([body] * count, terrains, tables, quiet(), seeds=0)
        assert all(o.finite for o in outcomes)
        assert np.all(np.isfinite(trace.com))
        # The rope limits keep the blocks apart: no voxel turns inside out (a mirrored
        # voxel's signed area is negative).
        assert trace.min_area.min() > 0.2
        assert all(o.min_signed_area_ratio == a for o, a in zip(outcomes, trace.min_area))


def _distance(body: Body, controller, terrain=FLAT, duration=10.0) -> float:
    config = quiet(duration=duration, start_gap=100.0)
    [outcome], _ = simulate_batch([body], [terrain], [controller], config)
    return outcome.distance


def test_travelling_waves_move_the_worm_both_ways(worm):
    # A quarter period per column: the reference simulator's fastest slow worm gait
    # (1.26 m/s on flat ground at 1 Hz, shared/reference).
    forward = _distance(worm, Sine(1.0, 1.0, -math.pi / 2))
    backward = _distance(worm, Sine(1.0, 1.0, math.pi / 2))
    assert forward > 2.0
    assert backward < -2.0
    assert 0.8 < -backward / forward < 1.25
    # A synchronous gait has no direction: it drifts by chaos, either way, by up to 3 m in
    # 10 s for amplitudes and phases 1e-3 apart (BENCHMARKS.md), so its mean drift over a few.
    gaits = [Sine(1.0, amp, phase) for amp in (1.0, 0.999, 0.995) for phase in (0.0, 1e-3)]
    config = quiet(duration=10.0, start_gap=100.0)
    outcomes, _ = simulate_batch([worm] * len(gaits), [FLAT] * len(gaits), gaits, config)
    assert np.mean([abs(o.distance) for o in outcomes]) < 0.1 * forward


def test_uphill_gives_less_headway(worm):
    gait = Sine(1.0, 1.0, -math.pi / 2)
    config = quiet(duration=10.0)
    [flat], _ = simulate_batch([worm], [FLAT], [gait], config)
    [uphill], _ = simulate_batch([worm], [parse_terrain("uphill-20")], [gait], config)
    assert 0.0 < uphill.distance < 0.75 * flat.distance


def test_tilt_is_the_angle_between_the_end_columns():
    """The tilt diagnostic: |angle| of the line from the leftmost column's centre to the
    rightmost's, 0 upright, 90 standing on its end, about 180 upside down."""
    from somite.tasks.episode import _column_tilt

    voxel_x = np.array([0.0, 1.0, 1.0, 2.0])
    voxels = np.zeros((4, 6))
    voxels[1:3, :2] = 99.0  # middle columns do not count

    def tilt(left, right):
        voxels[0, :2] = left
        voxels[3, :2] = right
        return _column_tilt(4, voxel_x, 0.0, 2.0, voxels)

    assert tilt((0.0, 0.0), (6.0, 1.5)) == pytest.approx(np.degrees(np.arctan(1.5 / 6)))
    assert tilt((0.0, 0.0), (0.0, 7.5)) == pytest.approx(90.0)
    assert tilt((6.0, 0.0), (0.0, 0.0)) == pytest.approx(180.0)
    assert tilt((0.0, 0.0), (-6.0, -3.0)) == pytest.approx(180.0 - np.degrees(np.arctan(0.5)))
    # A column of two voxels counts by its centre.
    two = np.array([[0.0, 0.0], [0.0, 3.0], [6.0, 6.0], [6.0, 9.0]])
    assert _column_tilt(4, np.array([0.0, 0.0, 1.0, 1.0]), 0.0, 1.0,
                        np.c_[two, np.zeros((4, 4))]) == pytest.approx(45.0)
    assert _column_tilt(4, np.zeros(4), 0.0, 0.0, voxels) == 0.0  # one column: no line


def test_upright_worm_diagnostics(worm):
    """A worm at rest: no tilt, never on its side, lowest corner on the ground, voxels near
    their rest area."""
    [outcome], _ = simulate_batch([worm], [FLAT], [Zero()], quiet(duration=8.0))
    assert outcome.max_tilt_deg < 1.0
    assert outcome.flipped_fraction == 0.0
    assert abs(outcome.max_height) < 0.02
    assert 0.95 < outcome.min_signed_area_ratio < 1.0


def test_a_jump_shows_as_height(worm):
    """All voxels pulsing together make the worm hop: its lowest corner leaves the ground."""
    config = quiet(duration=10.0)
    [hop], _ = simulate_batch([worm], [FLAT], [Sine(2.0, 1.0, 0.0)], config)
    [crawl], _ = simulate_batch([worm], [FLAT], [Sine(0.5, 1.0, -1.0)], config)
    assert hop.max_height > 1.0
    assert crawl.max_height < 0.1
