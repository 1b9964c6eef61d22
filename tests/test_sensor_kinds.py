"""The table of sensor kinds (somite.sim.sensor_kinds): every row checked the same way, from the
body's reading slots through the batch arrays and the kernel's noise to the drawn frame."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from somite.brain.controllers import Zero
from somite.sim.body import SENSOR_KINDS, Body
from somite.sim.config import LIDAR_ORIGINAL, SimConfig, preset
from somite.sim.sensor_kinds import (
    NOISE_STRIDE,
    READING_COMPONENT,
    READING_KIND,
    SENSOR_CODE,
    SENSORS,
)
from somite.sim.sensors import noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import simulate_batch
from somite.viz.frame import render_frame
from somite.viz.video import record_episode

from .conftest import quiet

FLAT = parse_terrain("flat")
KINDS = [pytest.param(kind, id=kind.name) for kind in SENSORS]


def only(kind, shape="worm") -> Body:
    """A body whose every voxel has one sensor: of ``kind``."""
    body = Body.build(shape, "none")
    return Body.build(body.shape, {cell: [kind.name] for cell in body.shape.voxels})


def test_the_table_is_the_body_s_list_of_kinds():
    assert SENSOR_KINDS == tuple(kind.name for kind in SENSORS)
    assert [SENSOR_CODE[kind.name] for kind in SENSORS] == list(range(len(SENSORS)))
    assert len({kind.colour for kind in SENSORS}) == len(SENSORS)
    # Reading codes number the (kind, component) pairs in the table's order.
    pairs = [(code, c) for code, kind in enumerate(SENSORS) for c in range(kind.width)]
    assert list(zip(READING_KIND.tolist(), READING_COMPONENT.tolist())) == pairs


@pytest.mark.parametrize("kind", KINDS)
def test_a_kind_s_readings_are_its_width_of_codes_and_components(kind):
    body = only(kind)
    n = body.shape.n_voxels
    assert body.n_readings == kind.width * n
    system = compile_system([body], [FLAT])
    assert system.n_readings.tolist() == [kind.width * n]
    codes = system.reading_code[0]
    assert (READING_KIND[codes] == SENSOR_CODE[kind.name]).all()
    assert READING_COMPONENT[codes].tolist() == list(range(kind.width)) * n
    assert system.reading_voxel[0].tolist() == np.repeat(np.arange(n), kind.width).tolist()


ALTERED = {"touch_window": 5, "velocity_window": 4, "velocity_frame": "voxel",
           "velocity_max": 2.0, "lidar_range": 5.0, "lidar_angles": LIDAR_ORIGINAL,
           "lidar_frame": "voxel"}
"""Another value of every sensor setting."""
SETTINGS = [pytest.param(kind, name, id=name) for kind in SENSORS for name in kind.settings]


def test_settings_are_options_of_one_kind_each():
    names = [name for kind in SENSORS for name in kind.settings]
    assert len(set(names)) == len(names)
    assert set(names) <= {field.name for field in dataclasses.fields(SimConfig)}
    assert set(names) == set(ALTERED)


@pytest.fixture(scope="module")
def all_sensors():
    """A worm with every sensor on every voxel, and its readings (T, R) on flat ground."""
    body = Body.build("worm", "all")

    def readings(**options):
        _, trace = simulate_batch([body], [FLAT], [Zero()], quiet(duration=1.5, **options),
                                  record=True)
        return trace.readings[0, 1:]

    return body, readings, readings()


@pytest.mark.parametrize("kind, name", SETTINGS)
def test_a_setting_changes_its_kind_s_readings_only(all_sensors, kind, name):
    body, readings, default = all_sensors
    changed = (readings(**{name: ALTERED[name]}) != default).any(axis=0)
    mine = np.array([r.kind == kind.name for r in body.readings])
    assert changed[mine].any() and not changed[~mine].any()


@pytest.mark.parametrize("kind", KINDS)
def test_readings_without_noise_are_normalised(kind):
    body = only(kind)
    _, trace = simulate_batch([body], [FLAT], [Zero()], quiet(duration=1.5), record=True)
    readings = trace.readings[0, 1:, : body.n_readings]
    assert np.isfinite(readings).all()
    assert ((readings >= 0.0) & (readings <= 1.0)).all()


@pytest.mark.parametrize("kind", KINDS)
def test_the_authors_noise_follows_the_kind_s_stride(kind):
    # A Zero controller: the noise changes the readings, never the motion.
    body = only(kind)
    config = preset("original-code", duration=0.5, noise_sigma=0.0)
    noisy = config.with_options(noise_sigma=0.25)
    runs = [simulate_batch([body], [FLAT], [Zero()], c, record=True)[1] for c in (config, noisy)]
    table = noise_table(noisy)
    assert len(table) == NOISE_STRIDE.max() * noisy.n_steps
    step = np.arange(noisy.n_steps)[:, None]  # the sensing step of trace row step + 1
    component = np.tile(np.arange(kind.width), body.shape.n_voxels)[None, :]
    expected = 0.25 * table[kind.noise_stride * step + component]
    added = runs[1].readings[0, 1:] - runs[0].readings[0, 1:]
    np.testing.assert_allclose(added, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_frames_draw_a_kind_s_readings_in_its_colour(kind):
    recording = record_episode(only(kind), Zero(), "flat", quiet(duration=1.5), seed=0)
    step = recording.n_steps

    def painted(sensors):
        image = np.asarray(render_frame(recording, step, 640, 360, supersample=1,
                                        sensors=sensors).image)
        return int((image == kind.colour).all(axis=-1).sum())

    assert painted(True) > painted(False) + 20
