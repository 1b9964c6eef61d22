"""Terrains: the authors' generator bit for bit, walls, slopes and bad names."""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.errors import SomiteError
from somite.sim.java_random import JavaRandom
from somite.sim.terrain import LENGTH, WALL_HEIGHT, WALL_WIDTH, hilly, parse_terrain


def hilly_reference(height: float, width: float, seed: int) -> tuple[list, list]:
    """The authors' hilly profile in plain Python with JavaRandom: the oracle of the compiled
    one (their loop, written as they wrote it)."""
    rng = JavaRandom(seed)
    xs = [0.0, WALL_WIDTH]
    ys = [WALL_HEIGHT, 0.0]
    while xs[-1] < LENGTH - WALL_WIDTH:
        xs.append(xs[-1] + max(1.0, (rng.next_gaussian() * 0.25 + 1) * width))
        ys.append(ys[-1] + rng.next_gaussian() * height)
    xs.append(xs[-1] + WALL_WIDTH)
    ys.append(WALL_HEIGHT)
    return xs, ys


def test_java_random_matches_java():
    # Values printed by java.util.Random on the JVM.
    assert JavaRandom(0).next_double() == 0.730967787376657
    assert JavaRandom(0).next_gaussian() == 0.8025330637390305
    rng = JavaRandom(42)
    assert [rng.next_int(10) for _ in range(5)] == [0, 3, 8, 4, 0]


@pytest.mark.parametrize("name", ["flat", "hilly-1-10-0", "steppy-1-10-3", "uphill-20",
                                  "downhill-10"])
def test_terrains_are_walled_profiles_of_2000_m(name):
    terrain = parse_terrain(name)
    assert np.all(np.diff(terrain.xs) > 0)
    assert terrain.xs[0] == 0 and terrain.xs[-1] >= 2000 - 1e-9
    assert terrain.ys[0] >= terrain.ys[1] + 100 - 1e-9  # the left wall
    assert terrain.ys[-1] > terrain.ys[-2] + 50  # the right wall (y = 100 for hilly, as the
    # authors build it, whatever the height of the last hill)
    assert terrain.start_x == 10


def test_hilly_follows_the_authors_random_walk():
    terrain = parse_terrain("hilly-1-10-7")
    rng = JavaRandom(7)
    x, y = 10.0, 0.0
    for i in range(2, 6):
        x += max(1.0, (rng.next_gaussian() * 0.25 + 1) * 10)
        y += rng.next_gaussian() * 1
        assert (terrain.xs[i], terrain.ys[i]) == (x, y)
    steps = np.diff(terrain.ys[1:-1])
    assert 0.7 < steps.std() < 1.3  # height steps N(0, 1)
    assert parse_terrain("hilly-1-10-7").ys.tolist() == terrain.ys.tolist()
    assert parse_terrain("hilly-1-10-8").ys.tolist() != terrain.ys.tolist()


def test_slopes_have_their_angle():
    terrain = parse_terrain("uphill-20")
    slope = (terrain.ys[2] - terrain.ys[1]) / (terrain.xs[2] - terrain.xs[1])
    assert math.isclose(slope, math.tan(math.radians(20)))
    down = parse_terrain("downhill-20")
    assert math.isclose((down.ys[2] - down.ys[1]) / (down.xs[2] - down.xs[1]), -slope)


@pytest.mark.parametrize("name", ["bumpy", "hilly-1-10", "hilly-a-10-0", "uphill-75", "",
                                  "hilly-1-10-9223372036854775808", "hilly-1-0-3"])
def test_bad_terrain_names(name):
    with pytest.raises(SomiteError, match="^terrain="):
        parse_terrain(name)


@pytest.mark.parametrize("seed", [0, 1, 42, 9999, 2**31 + 7])
@pytest.mark.parametrize("height, width", [(1.0, 10.0), (2.5, 4.0)])
def test_compiled_hilly_equals_the_java_random_reference(seed, height, width):
    terrain = hilly(height, width, seed)
    xs, ys = hilly_reference(height, width, seed)
    assert terrain.xs.tolist() == xs and terrain.ys.tolist() == ys
