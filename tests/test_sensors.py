"""Sensors read what geometry says."""

from __future__ import annotations

import numpy as np
import pytest

from somite.brain.controllers import Sine, Table, Zero
from somite.sim.config import LIDAR_PAPER, preset
from somite.sim.sensors import ANGLE_MEAN, NO_ANGLE, VECTOR_MEAN, voxel_state
from somite.sim.system import geometry
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.locomotion import simulate_batch

from .conftest import quiet, voxel_geometry

FLAT = parse_terrain("flat")


def _readings_of(body, voxel, kind):
    return [i for i, r in enumerate(body.readings) if r.voxel == voxel and r.kind == kind]


def _ray_distance(origin, angle, terrain, reach=10.0):
    """Independent oracle: nearest intersection of a ray with the terrain's segments."""
    direction = np.array([np.cos(angle), np.sin(angle)])
    best = reach
    for i in range(len(terrain.xs) - 1):
        a = np.array([terrain.xs[i], terrain.ys[i]])
        b = np.array([terrain.xs[i + 1], terrain.ys[i + 1]])
        matrix = np.column_stack([direction, a - b])
        if abs(np.linalg.det(matrix)) < 1e-12:
            continue
        t, u = np.linalg.solve(matrix, a - origin)
        if 0 <= t < best and 0 <= u <= 1:
            best = t
    return best


def _check_lidar(body, trace, terrain, step):
    centres, _ = voxel_geometry(body, trace.pos[0, step])
    checked = 0
    for v, kinds in enumerate(body.sensors):
        if "lidar" not in kinds:
            continue
        for ray, index in enumerate(_readings_of(body, v, "lidar")):
            expected = _ray_distance(centres[v], LIDAR_PAPER[ray], terrain) / 10.0
            assert abs(trace.readings[0, step, index] - expected) <= 0.01 * expected
            checked += 1
    return checked


def test_lidar_on_flat_ground(worm):
    config = quiet(duration=3.0)
    _, trace = simulate_batch([worm], [FLAT], [Zero()], config, record=True)
    assert _check_lidar(worm, trace, FLAT, config.n_steps) == 10
    # The bottom-right voxel's downward rays hit the ground, its level and upward ones nothing.
    lidar = _readings_of(worm, worm.shape.index(5, 0), "lidar")
    values = trace.readings[0, -1, lidar]
    assert np.all(values[:2] < 1.0) and np.all(values[2:] == 1.0)


def test_lidar_against_the_right_wall(worm):
    # Put the worm's right edge 4 m before the foot of the right wall (x = 1990).
    config = quiet(duration=3.0, start_gap=1990.0 - 4.0 - 18.0 - 10.0)
    _, trace = simulate_batch([worm], [FLAT], [Zero()], config, record=True)
    assert _check_lidar(worm, trace, FLAT, config.n_steps) == 10
    level = _readings_of(worm, worm.shape.index(5, 1), "lidar")[2]
    assert trace.readings[0, -1, level] < 0.6  # the horizontal ray sees the wall


def test_touch_is_one_exactly_when_a_corner_touches(worm):
    terrain = hilly(1.0, 10.0, 3)
    _, trace = simulate_batch([worm], [terrain], [Sine(1.5, 1.0, -1.0)], quiet(duration=6.0),
                        record=True)
    corners = geometry(worm).corners
    compared = 0
    for v, kinds in enumerate(worm.sensors):
        if "touch" not in kinds:
            continue
        [index] = _readings_of(worm, v, "touch")
        touching = trace.contact[0][:, corners[v]].any(axis=1)[1:]
        np.testing.assert_array_equal(trace.readings[0, 1:, index], touching.astype(float))
        compared += 1
    assert compared == 6
    assert trace.readings[0, 1:, _readings_of(worm, 0, "touch")[0]].min() == 0.0  # falling


def test_area_ratio_at_rest_and_under_actuation(worm):
    config = quiet(duration=4.0)
    contract = Table(np.ones((1, worm.shape.n_voxels)))
    expand = Table(-np.ones((1, worm.shape.n_voxels)))
    _, trace = simulate_batch([worm] * 3, [FLAT] * 3, [Zero(), contract, expand], config,
                              record=True)
    areas = [voxel_geometry(worm, trace.pos[b, -1])[1] for b in range(3)]
    assert np.all(np.abs(areas[0] - 1.0) < 0.02)
    assert np.all(np.abs(areas[1] - (1 - 0.225)) < 0.03)
    assert np.all(np.abs(areas[2] - (1 + 0.225)) < 0.03)
    area_readings = [i for i, r in enumerate(worm.readings) if r.kind == "area"]
    at_rest, contracted, expanded = (trace.readings[b, -1, area_readings] for b in range(3))
    # Soft normalisation: 0.5 + 0.5 tanh(4 (A - 1)).
    np.testing.assert_allclose(at_rest, 0.5 + 0.5 * np.tanh(4 * (areas[0] - 1)), atol=1e-9)
    assert np.all(contracted < at_rest - 0.2) and np.all(expanded > at_rest + 0.2)


def test_noise_is_gaussian_with_sigma_and_seeded(worm):
    # The zero controller ignores its readings: noise changes the readings, not the motion.
    config = quiet(duration=5.0)
    noisy = config.with_options(noise_sigma=0.01)
    _, clean = simulate_batch([worm], [FLAT], [Zero()], config, record=True)
    _, first = simulate_batch([worm], [FLAT], [Zero()], noisy, seeds=7, record=True)
    _, again = simulate_batch([worm], [FLAT], [Zero()], noisy, seeds=7, record=True)
    _, other = simulate_batch([worm], [FLAT], [Zero()], noisy, seeds=8, record=True)
    noise = (first.readings - clean.readings)[0, 1:]
    assert abs(noise.std() - 0.01) < 0.0005 and abs(noise.mean()) < 0.0005
    np.testing.assert_array_equal(first.readings, again.readings)
    assert not np.array_equal(first.readings, other.readings)


# java.util.Random(0).nextGaussian(), #1..#10, as printed by Java.
JAVA_RANDOM_0 = (0.8025330637390305, -0.9015460884175122, 2.080920790428163, 0.7637707684364894,
                 0.9845745328825128, -1.6834122587673428, -0.027290262907887285,
                 0.11524570286202315, -0.39016704137993774, -0.643388813126449)


def test_original_code_noise_is_the_authors_java_random_0_stream(worm):
    """Every sensor restarts Random(0) each episode: at step k a 1-D sensor adds Gaussian #k,
    the velocity #2k-1 and #2k, the lidar #5k-4..#5k, whatever the voxel, robot or seed."""
    noisy = preset("original-code", duration=2 / 60)
    assert noisy.noise_stream == "java-random-0" and noisy.noise_sigma == 0.01
    clean = noisy.with_options(noise_sigma=0.0)
    _, exact = simulate_batch([worm], [FLAT], [Zero()], clean, record=True)
    _, batch = simulate_batch([worm] * 2, [FLAT] * 2, [Zero()] * 2, noisy, seeds=[3, 4],
                              record=True)
    _, again = simulate_batch([worm], [FLAT], [Zero()], noisy, seeds=9, record=True)
    width = {"area": 1, "touch": 1, "velocity": 2, "lidar": 5}
    expected = np.array([
        [0.01 * JAVA_RANDOM_0[width[r.kind] * (k - 1) + r.component] for r in worm.readings]
        for k in (1, 2)
    ])
    assert {r.kind for r in worm.readings} == set(width)
    for trace in (batch, batch, again):
        np.testing.assert_allclose(trace.readings[0, 1:] - exact.readings[0, 1:], expected,
                                   rtol=0, atol=1e-15)
    np.testing.assert_array_equal(batch.readings[1], batch.readings[0])
    # The paper preset keeps somite's independent noise.
    assert preset("paper").noise_stream == "independent"


def _quad(sw, se, ne, nw):
    """One voxel's corner positions (4, 2) and corner indices (1, 4) in kernel order."""
    return np.array([sw, se, ne, nw], dtype=float), np.array([[0, 1, 2, 3]], dtype=np.int32)


@pytest.mark.parametrize(
    "corners, vector_mean, angle_mean",
    [
        # Bottom side at 0.1 rad (length 3), top side at 0.3 rad (length 2).
        (((0, 0), (3 * np.cos(0.1), 3 * np.sin(0.1)), (2 * np.cos(0.3), 3 + 2 * np.sin(0.3)),
          (0, 3)),
         np.arctan2(3 * np.sin(0.1) + 2 * np.sin(0.3), 3 * np.cos(0.1) + 2 * np.cos(0.3)), 0.2),
        # Upside down: top side at pi - 0.05, bottom side at -pi + 0.05; the mean of the two
        # angles is 0, 180 degrees from the voxel's orientation.
        (((3, 3), (3 - 3 * np.cos(0.05), 3 - 3 * np.sin(0.05)),
          (-3 * np.cos(0.05), 3 * np.sin(0.05)), (0, 0)), np.pi, 0.0),
    ],
)
def test_voxel_angle_modes_by_hand(corners, vector_mean, angle_mean):
    pos, index = _quad(*corners)
    out = np.zeros((1, 6))
    for mode, expected in ((VECTOR_MEAN, vector_mean), (ANGLE_MEAN, angle_mean), (NO_ANGLE, 0)):
        voxel_state(1, index, pos, np.zeros((4, 2)), mode, out)
        wrapped = (out[0, 5] - expected + np.pi) % (2 * np.pi) - np.pi  # pi and -pi are one angle
        assert abs(wrapped) < 1e-12, (mode, out[0, 5], expected)


def _hand_angle(quad, mode):
    sw, se, ne, nw = quad
    bottom, top = se - sw, ne - nw
    if mode == "vector-mean":
        total = bottom + top
        return np.arctan2(total[1], total[0])
    return 0.5 * (np.arctan2(top[1], top[0]) + np.arctan2(bottom[1], bottom[0]))


@pytest.mark.parametrize("mode, other", [("vector-mean", "angle-mean"),
                                         ("angle-mean", "vector-mean")])
def test_voxel_frame_lidar_turns_with_the_configured_voxel_angle(worm, mode, other):
    terrain = hilly(1.0, 10.0, 5)
    config = quiet(duration=3.0, lidar_frame="voxel", voxel_angle=mode)
    _, trace = simulate_batch([worm], [terrain], [Sine(2.0, 1.0, -1.0)], config, record=True)
    corners = geometry(worm).corners
    checked, told_apart = 0, 0
    for step in range(30, config.n_steps + 1, 30):
        quads = trace.pos[0, step][corners]
        for v, kinds in enumerate(worm.sensors):
            if "lidar" not in kinds:
                continue
            centre = quads[v].mean(axis=0)
            for ray, index in enumerate(_readings_of(worm, v, "lidar")):
                angle = LIDAR_PAPER[ray] + _hand_angle(quads[v], mode)
                wrong = LIDAR_PAPER[ray] + _hand_angle(quads[v], other)
                reading = trace.readings[0, step, index]
                assert abs(reading - _ray_distance(centre, angle, terrain) / 10) < 1e-9
                told_apart += abs(reading - _ray_distance(centre, wrong, terrain) / 10) > 1e-7
                checked += 1
    assert checked == 60 and told_apart > 0
