"""The gait summary (``somite gait``): frequencies, phases, still voxels, duty factors and the
line of words, on made-up recordings whose answer is known, and on simulated ones."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from somite.analysis.gait import STILL_AMPLITUDE, analyse_gait
from somite.brain.controllers import Sine
from somite.cli import main
from somite.evolution.operators import initial_genome
from somite.sim.body import Body
from somite.sim.config import CONTROL_HZ, preset
from somite.sim.system import geometry
from somite.viz.video import record_episode

WORM = Body.build("worm")
CONFIG = preset("paper", duration=10.0)  # analysed over [5 s, 10 s]: 300 rows, 0.2 Hz bins
T = np.arange(CONFIG.n_steps + 1) / CONTROL_HZ
COLUMNS = np.array([x for x, _ in WORM.shape.voxels], dtype=float)


def made_up(actuation, velocity=1.0, contact=None, com_x=None, config=CONFIG):
    corners = geometry(WORM).corners.astype(np.int64)
    n_points = int(corners.max()) + 1
    t = np.arange(config.n_steps + 1) / CONTROL_HZ
    com = np.zeros((len(t), 2))
    com[:, 0] = velocity * t if com_x is None else com_x
    return SimpleNamespace(
        body=WORM, config=config, actuation=np.asarray(actuation, dtype=float),
        contact=np.zeros((len(t), n_points), bool) if contact is None else contact,
        corners=corners, com=com, velocity=velocity)


def test_one_vibrating_voxel_among_still_ones():
    act = np.full((len(T), WORM.shape.n_voxels), -0.3)
    act[:, 3] = 0.94 * np.sign(np.sin(2 * np.pi * 10 * T + 0.1))  # a 10 Hz square wave
    gait = analyse_gait(made_up(act, velocity=3.5))
    assert gait.moving == [3] and gait.still == [v for v in range(12) if v != 3]
    assert gait.frequency == pytest.approx(10.0)
    assert gait.voxels[3].amplitude == pytest.approx(0.94)
    assert all(gait.voxels[v].mean == pytest.approx(-0.3) for v in gait.still)
    assert gait.pattern == "vibration"
    assert gait.description == ("voxel 3 vibrates at 10 Hz, the rest hold a pose; progress by "
                                "vibration, forward at 3.50 m/s")


@pytest.mark.parametrize("velocity,words", [(2.0, "back to front"), (-2.0, "front to back")])
def test_a_travelling_wave_is_named_with_its_direction(velocity, words):
    # sin(2 pi f t - x): a voxel peaks 1 rad later than its left neighbour: a wave towards +x.
    act = 0.8 * np.sin(2 * np.pi * 2.0 * T[:, None] - COLUMNS[None, :])
    gait = analyse_gait(made_up(act, velocity=velocity))
    assert gait.frequency == pytest.approx(2.0)
    assert gait.still == []
    assert gait.description.startswith(f"travelling wave {words} at 2 Hz (12 of 12 voxels)")
    # Phases relative to the back voxels fall by 1 rad a column.
    for v in gait.voxels:
        assert math.cos(v.phase + v.x) == pytest.approx(1.0, abs=1e-6)


def test_voxels_in_phase_and_in_two_groups():
    together = analyse_gait(made_up(np.repeat(np.sin(2 * np.pi * 1.4 * T)[:, None], 12, 1)))
    assert together.pattern == "together"
    assert together.description == "the voxels pulse together at 1.4 Hz; forward at 1.00 m/s"
    sign = np.where(np.arange(12) % 2 == 0, 1.0, -1.0)
    halves = analyse_gait(made_up(np.sin(2 * np.pi * 3 * T)[:, None] * sign, velocity=0.01))
    assert halves.pattern == "alternating" and halves.description.endswith("it barely moves")


def test_a_slow_drift_of_posture_is_not_the_rhythm():
    # 30 s, measured over 25 s: 0.04 Hz bins. Every voxel drifts by 0.6 over one slow cycle
    # while two groups alternate at 3 Hz with half that swing.
    config = preset("paper", duration=30.0)
    t = np.arange(config.n_steps + 1) / CONTROL_HZ
    drift = 0.6 * np.sin(2 * np.pi * 0.04 * (t - 5.0))[:, None]
    sign = np.where(np.arange(12) % 2 == 0, 1.0, -1.0)
    gait = analyse_gait(made_up(drift + 0.3 * np.sin(2 * np.pi * 3 * t)[:, None] * sign,
                                config=config))
    assert gait.frequency == pytest.approx(3.0)
    assert gait.description == ("two groups of voxels pulse in alternation at 3 Hz; forward at "
                                "1.00 m/s")
    # A voxel that only drifts keeps its own frequency, written to two significant digits, and
    # is said to drift: slower than MIN_RHYTHM_HZ is a drift of posture, not a swing.
    alone = np.full((len(t), 12), -0.3)
    alone[:, 3] = drift[:, 0]
    gait = analyse_gait(made_up(alone, config=config))
    assert gait.voxels[3].frequency == pytest.approx(0.04)
    assert gait.description == ("voxel 3 drifts at 0.04 Hz, the rest hold a pose; forward at "
                                "1.00 m/s")


def test_still_robot_and_duty_factor_and_stride():
    act = np.full((len(T), 12), 0.5) + 0.4 * STILL_AMPLITUDE * np.sin(7 * T)[:, None]
    corners = geometry(WORM).corners
    contact = np.zeros((len(T), int(corners.max()) + 1), bool)
    contact[::4, corners[0, 0]] = True  # voxel 0 touches every 4th step
    contact[:, corners[1, 1]] = True  # voxel 1 always
    com_x = 0.5 * T + 0.05 * np.sin(2 * np.pi * 3.0 * T)  # surging three times a second
    gait = analyse_gait(made_up(act, velocity=0.5, contact=contact, com_x=com_x))
    assert gait.pattern == "still" and gait.moving == []
    assert gait.description == "every voxel holds a pose; forward at 0.50 m/s"
    assert gait.voxels[0].duty == pytest.approx(0.25, abs=0.01)
    assert gait.voxels[1].duty == 1.0 and gait.voxels[2].duty == 0.0
    assert gait.stride_frequency == pytest.approx(3.0)


def test_a_simulated_sine_worm_walks_as_a_wave_at_its_frequency():
    recording = record_episode(WORM, Sine(freq=2.0, phase=-1.0), "flat", CONFIG, seed=0)
    gait = analyse_gait(recording)
    assert gait.frequency == pytest.approx(2.0) and gait.still == []
    assert gait.pattern.startswith("wave")
    ahead = "back to front" if recording.velocity >= 0 else "front to back"
    assert ahead in gait.description
    assert all(0 <= v.duty <= 1 for v in gait.voxels)
    bottom = np.mean([v.duty for v in gait.voxels if v.y == 0])
    top = np.mean([v.duty for v in gait.voxels if v.y == 1])
    assert bottom > max(top, 0.05)  # it walks on its bottom row


def test_gait_command_prints_words_json_and_draws(tmp_path, capsys):
    path = tmp_path / "worm.json"
    initial_genome(WORM, np.random.default_rng(0)).save(path)
    picture = tmp_path / "gait.png"
    assert main(["gait", str(path), "--terrain", "flat", "--duration", "2",
                 "--picture", str(picture)]) == 0
    out = capsys.readouterr().out
    assert "gait: " in out and out.count("\n") >= 12 + 4
    with Image.open(picture) as image:
        assert image.width > 400
    assert main(["gait", str(path), "--terrain", "flat", "--duration", "2", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["voxels"]) == 12 and data["description"]
    assert main(["gait", str(path), "--picture", str(tmp_path / "g.jpg")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "extension" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gait.png", "worm.json"]
