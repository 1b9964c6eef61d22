"""Sensors read what geometry says."""

from __future__ import annotations

import numpy as np

from somite.brain.controllers import Sine, Table, Zero
from somite.sim.config import LIDAR_PAPER
from somite.sim.system import geometry
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.locomotion import simulate

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
    _, trace = simulate([worm], [FLAT], [Zero()], config, record=True)
    assert _check_lidar(worm, trace, FLAT, config.n_steps) == 10
    # The bottom-right voxel's downward rays hit the ground, its level and upward ones nothing.
    lidar = _readings_of(worm, worm.shape.index(5, 0), "lidar")
    values = trace.readings[0, -1, lidar]
    assert np.all(values[:2] < 1.0) and np.all(values[2:] == 1.0)


def test_lidar_against_the_right_wall(worm):
    # Put the worm's right edge 4 m before the foot of the right wall (x = 1990).
    config = quiet(duration=3.0, start_gap=1990.0 - 4.0 - 18.0 - 10.0)
    _, trace = simulate([worm], [FLAT], [Zero()], config, record=True)
    assert _check_lidar(worm, trace, FLAT, config.n_steps) == 10
    level = _readings_of(worm, worm.shape.index(5, 1), "lidar")[2]
    assert trace.readings[0, -1, level] < 0.6  # the horizontal ray sees the wall


def test_touch_is_one_exactly_when_a_corner_touches(worm):
    terrain = hilly(1.0, 10.0, 3)
    _, trace = simulate([worm], [terrain], [Sine(1.5, 1.0, -1.0)], quiet(duration=6.0),
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
    _, trace = simulate([worm] * 3, [FLAT] * 3, [Zero(), contract, expand], config, record=True)
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
    _, clean = simulate([worm], [FLAT], [Zero()], config, record=True)
    _, first = simulate([worm], [FLAT], [Zero()], noisy, seeds=7, record=True)
    _, again = simulate([worm], [FLAT], [Zero()], noisy, seeds=7, record=True)
    _, other = simulate([worm], [FLAT], [Zero()], noisy, seeds=8, record=True)
    noise = (first.readings - clean.readings)[0, 1:]
    assert abs(noise.std() - 0.01) < 0.0005 and abs(noise.mean()) < 0.0005
    np.testing.assert_array_equal(first.readings, again.readings)
    assert not np.array_equal(first.readings, other.readings)
