"""The contact search and the diagnostics skip the blocks that :func:`ground_top`'s bound puts
clear of the ground; what they skip is only what their exact tests would have left out, so
the numbers are the same (``audits/traces.py`` checks whole episodes against earlier commits):
a skipped block has no vertex at or below any segment its box reaches, and the lowest corner's
gap is the minimum over every corner whatever segment each search starts from."""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite._jit import njit
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.physics import (
    CLEAR_REACH,
    HALF_BLOCK,
    block_polygon,
    ground_height,
    ground_top,
    lowest_gap,
    world_point,
)
from somite.sim.robot import ground_view, robot_view
from somite.sim.system import compile_system
from somite.sim.terrain import hilly


@njit
def _every_corner_gap(robot, ground, pos, cos, sin):
    """The lowest corner's gap, every corner of every block, each search from segment 0."""
    gap = math.inf
    for p in range(robot.n_points):
        for j in range(4):
            lx = HALF_BLOCK if j == 1 or j == 2 else -HALF_BLOCK
            ly = HALF_BLOCK if j >= 2 else -HALF_BLOCK
            x, y = world_point(p, lx, ly, pos, cos, sin)
            gap = min(gap, y - ground_height(ground.xs, ground.ys, ground.n, x, 0))
    return gap


def _world(shape="worm", seed=3):
    system = compile_system([Body.build(shape)], [hilly(1.0, 10.0, seed)])
    return robot_view(system, 0, pack_params(SimConfig())), ground_view(system, 0)


def _poses(robot, ground, rng, count):
    """Blocks scattered over ~20 m of the terrain, from 0.5 m into the ground to 6 m above it,
    any rotation: (pos, cos, sin, segment guesses); some at the terrain's ends."""
    p = robot.n_points
    for i in range(count):
        lo = ground.xs[0] - 2.0 if i % 10 == 0 else ground.xs[0] + 5.0
        hi = ground.xs[ground.n - 1] - 20.0
        x0 = hi + 18.0 if i % 10 == 1 else rng.uniform(lo, hi)
        pos = np.empty((p, 3))
        pos[:, 0] = x0 + rng.uniform(0.0, 18.0, p)
        pos[:, 1] = np.interp(pos[:, 0], ground.xs[:ground.n], ground.ys[:ground.n])
        pos[:, 1] += rng.uniform(-0.5, 6.0, p)
        pos[:, 2] = rng.uniform(-np.pi, np.pi, p)
        guesses = rng.integers(0, ground.n + 3, p + 1)
        yield pos, np.cos(pos[:, 2]), np.sin(pos[:, 2]), guesses


@pytest.mark.parametrize("shape", ["worm", "biped"])
def test_the_lowest_gap_is_every_corners_minimum_from_any_starting_segment(shape):
    robot, ground = _world(shape)
    rng = np.random.default_rng(0)
    for pos, cos, sin, guesses in _poses(robot, ground, rng, 200):
        assert (lowest_gap(robot, ground, pos, cos, sin, guesses)
                == _every_corner_gap(robot, ground, pos, cos, sin))


def test_a_block_the_bound_skips_is_above_every_segment_its_box_reaches():
    robot, ground = _world()
    xs, ys, n = ground.xs, ground.ys, ground.n
    rng = np.random.default_rng(1)
    skipped = kept = 0
    poly = np.empty((4, 4))
    for pos, cos, sin, guesses in _poses(robot, ground, rng, 200):
        top = ground_top(xs, ys, n, pos, robot.n_points, guesses[-1])
        for p in range(robot.n_points):
            if not pos[p, 1] - CLEAR_REACH > top:
                kept += 1
                continue
            skipped += 1
            block_polygon(p, pos, cos, sin, poly)
            lo_x, hi_x, lo_y = poly[:, 0].min(), poly[:, 0].max(), poly[:, 1].min()
            for i in range(n - 1):
                if xs[i + 1] > lo_x and xs[i] < hi_x:  # the segments the search walks
                    assert lo_y >= max(ys[i], ys[i + 1])
    assert skipped > 1000 and kept > 1000


def test_the_bound_gives_up_where_the_robot_reaches_past_the_terrain():
    robot, ground = _world()
    xs, ys, n = ground.xs, ground.ys, ground.n
    pos = np.zeros((robot.n_points, 3))
    pos[:, 1] = 100.0
    pos[:, 0] = np.linspace(xs[0] + 10.0, xs[0] + 28.0, robot.n_points)
    assert math.isfinite(ground_top(xs, ys, n, pos, robot.n_points, 0))
    for x0 in (xs[0] + CLEAR_REACH / 2, xs[n - 1] - CLEAR_REACH / 2):
        pos[0, 0] = x0
        assert ground_top(xs, ys, n, pos, robot.n_points, 0) == math.inf
