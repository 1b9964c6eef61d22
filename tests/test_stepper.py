"""The Python stepper (somite.Episode) runs the compiled loop's start / control_step / finish:
stepped to the end it leaves run_batch's trace bit for bit; and the CPU kernel's groups of
robots give each robot the numbers it gets alone."""

from __future__ import annotations

import numpy as np
import pytest

import somite
from somite.bench import random_graph
from somite.brain.compile import compile_genome
from somite.brain.controllers import Zero
from somite.sim.body import Body
from somite.sim.config import pack_params, preset
from somite.sim.state import BODY_FIELDS, BODY_PARTS, BodyState
from somite.sim.sensors import lidar_rays, noise_table
from somite.sim.system import compile_system
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.episode import new_trace, robot_work, work_row
from somite.tasks.work import WORK_PARTS, Work, new_work, work_shape, work_sizes
from somite.tasks.lanes import GROUP_SIZE, NOT_TIMED, Batch, groups, new_groups, run_groups
from somite.tasks.locomotion import compile_controllers, simulate_batch
from somite.tasks.stepper import Episode, start_batch, step_batch, step_in_groups

from .conftest import evolved, expect_error

TERRAIN = "hilly-1-10-7"
SEEDS = [21, 22]


@pytest.fixture(scope="module")
def batch():
    """A worm and a biped with evolved graph controllers, on a hilly terrain, noise on, 1 s."""
    genomes = [evolved("worm", 1), evolved("biped", 2)]
    config = preset("paper", duration=1.0)
    assert config.noise_sigma > 0
    bodies = [g.body for g in genomes]
    graphs = [compile_genome(g) for g in genomes]
    terrains = [parse_terrain(TERRAIN)] * 2
    _, reference = simulate_batch(bodies, terrains, graphs, config, SEEDS, record=True)
    return genomes, bodies, config, reference


def _assert_same(trace, reference, skip=()):
    for field in reference._fields:
        if field not in skip:
            assert np.array_equal(getattr(trace, field), getattr(reference, field),
                                  equal_nan=True), field


def test_stepping_to_the_end_gives_run_batchs_trace(batch):
    genomes, _, config, reference = batch
    assert (reference.status == 0).all()
    episode = somite.Episode(genomes, TERRAIN, config, SEEDS, record=True)
    assert episode.k == 0 and np.array_equal(episode.com, reference.com[:, 0])
    for k in range(1, config.n_steps + 1):
        episode.step()
        if k == 30:  # the views follow the steps
            assert episode.k == 30
            assert np.array_equal(episode.com, reference.com[:, 30])
            assert np.array_equal(episode.readings, reference.readings[:, 30])
            assert np.array_equal(episode.positions, reference.pos[:, 30])
            assert np.array_equal(episode.actuation, reference.actuation[:, 30])
    assert episode.done
    _assert_same(episode.trace, reference)
    assert np.array_equal(episode.diagnostics, reference.diagnostics)
    assert abs(reference.com[0, -1, 0] - reference.com[1, -1, 0]) > 1e-6  # two robots
    with pytest.raises(ValueError):  # views, not handles on the state
        episode.readings[0, 0] = 1.0


def test_supplying_the_controllers_own_actuation_changes_nothing(batch):
    genomes, _, config, reference = batch
    episode = Episode(genomes, TERRAIN, config, SEEDS, record=True)
    for k in range(1, config.n_steps + 1):
        # In force over step k: what the controller decided at step k - 1.
        episode.step(reference.actuation[:, k - 1])
    _assert_same(episode.trace, reference)


def test_zero_actuation_is_the_zero_controller(batch):
    genomes, bodies, config, _ = batch
    _, still = simulate_batch(bodies, [parse_terrain(TERRAIN)] * 2, [Zero(), Zero()], config,
                              SEEDS, record=True)
    episode = Episode(genomes, TERRAIN, config, SEEDS, record=True)
    zeros = np.zeros((2, episode.n_voxels))
    while not episode.done:
        episode.step(zeros)
    trace = episode.trace
    # The last row holds the graph's decision for a step that never comes.
    _assert_same(trace, still, skip={"actuation"})
    assert np.array_equal(trace.actuation[:, :-1], still.actuation[:, :-1])
    assert not np.array_equal(trace.actuation[:, -1], still.actuation[:, -1])


def test_bad_actuation_and_stepping_past_the_end_are_one_line_errors(batch):
    genomes, bodies, _, _ = batch
    config = preset("paper", duration=2 / 60)
    controllers = [Zero(), Zero()]
    episode = Episode(controllers, TERRAIN, config, SEEDS, bodies=bodies)
    width = episode.n_voxels
    message = expect_error("actuation", lambda: episode.step(np.zeros((2, width + 1))))
    assert f"(2, {width})" in message
    expect_error("actuation", lambda: episode.step(np.zeros(width)))
    expect_error("actuation", lambda: episode.step(np.full((2, width), 1.5)))
    expect_error("actuation", lambda: episode.step(np.full((2, width), np.nan)))
    assert episode.k == 0  # a refused step is not taken
    episode.step().step(np.ones((2, width)))
    assert episode.done
    message = expect_error("step", episode.step)
    assert "2 control steps" in message
    expect_error("bodies", lambda: Episode(controllers, TERRAIN, config))
    expect_error("terrains", lambda: Episode(genomes, [TERRAIN] * 3, config))


def test_the_work_arrays_follow_their_field_table():
    bodies = [Body.build("worm"), Body.build("biped")]
    genomes = [evolved("worm", 3, steps=5), evolved("biped", 4, steps=5)]
    config = preset("original-code", duration=0.1)
    episode = Episode(genomes, "flat", config)
    system, ctrl, params = episode.system, episode.controllers, pack_params(config)
    assert Work._fields == tuple(WORK_PARTS)
    assert BodyState._fields == tuple(BODY_FIELDS) == tuple(WORK_PARTS["physics"])
    assert [name for fields in BODY_PARTS.values() for name in fields] == list(BODY_FIELDS)
    batch = new_work(system, ctrl, params)
    padded = work_sizes(system, ctrl, params)
    for b in range(len(bodies)):
        sizes = work_sizes(system, ctrl, params, b)
        row, own = work_row(batch, b, system, ctrl, params), robot_work(system, ctrl, params, b)
        for part, fields in WORK_PARTS.items():
            if part != "tally":
                assert getattr(row, part)._fields == tuple(fields), part
            for name, (_, dtype) in fields.items():
                got_row, got_own, got_batch = (
                    work.tally if part == "tally" else getattr(getattr(work, part), name)
                    for work in (row, own, batch))
                expected = work_shape(name, sizes)
                assert got_row.shape == expected, name
                assert got_own.shape == expected, name
                assert got_batch.shape == (2, *work_shape(name, padded)), name
                assert got_own.dtype == got_row.dtype == dtype, name
                assert np.shares_memory(got_row, got_batch), name  # a view, not a copy
    assert work_sizes(system, ctrl, params, 0)["V"] != work_sizes(system, ctrl, params, 1)["V"]


def _alone_and_grouped(bodies, sizes, nan_robot=None):
    """Each robot's trace stepped alone (the stepper's per-robot path) and run_groups' trace
    for each group size, with the groups it formed."""
    rng = np.random.default_rng(5)
    graphs = [random_graph(body, 120, rng) for body in bodies]
    terrains = [hilly(1.0, 10.0, 30 + b) for b in range(len(bodies))]
    config = preset("paper", duration=0.5)
    system = compile_system(bodies, terrains, config.start_gap)
    if nan_robot is not None:
        system.initial_pos[nan_robot, 0, 0] = np.nan
    ctrl = compile_controllers(graphs, [b.shape.n_voxels for b in bodies])
    params, noise = pack_params(config), noise_table(config)
    seeds = np.arange(40, 40 + len(bodies), dtype=np.uint64)
    rays = lidar_rays(params)
    alone = new_trace(len(bodies), config.n_steps, system, True)
    work = new_work(system, ctrl, params, np.zeros)
    batch = Batch(system, ctrl, params, noise, seeds, config.n_steps, alone, work, rays)
    start_batch(batch)
    for k in range(1, config.n_steps + 1):
        step_batch(k, batch, np.zeros((0, system.voxel_corners.shape[1])))
    runs = []
    for size in sizes:
        first, count = groups(system, size, threads=1)
        grouped = new_trace(len(bodies), config.n_steps, system, True)
        run_groups(Batch(system, ctrl, params, noise, seeds, config.n_steps, grouped,
                         new_work(system, ctrl, params), rays), first, count)
        runs.append((first, count, grouped))
    return alone, runs


def test_robots_advanced_in_groups_give_each_robots_own_numbers():
    """The CPU kernel advances up to GROUP_SIZE robots of the same body together, their joints'
    velocity passes as vector lanes (somite.sim.joint_lanes); every group size leaves the trace
    of the per-robot path (the stepper's), bit for bit, also when a robot of a group stops (a
    NaN start: non-finite at the first step) and groups that differ in shape."""
    bodies = [Body.build("worm")] * 5 + [Body.build("biped")] * 2
    alone, runs = _alone_and_grouped(bodies, (1, 3, GROUP_SIZE), nan_robot=2)
    assert alone.status.tolist() == [0, 0, 1, 0, 0, 0, 0]
    for size, (_, count, grouped) in zip((1, 3, GROUP_SIZE), runs):
        assert count.max() == min(size, 5) and count.sum() == len(bodies)
        _assert_same(grouped, alone)


def test_robots_of_other_bodies_with_the_same_counts_are_not_grouped():
    """A row of three voxels and a column of three have as many blocks and joints, joined
    differently: a group shares its first robot's joints, so they never share a group, and
    each still gets its own numbers."""
    row, column = Body.build("3x1"), Body.build("1x3")
    bodies = [row, row, column, row, column, column]
    alone, [(first, count, grouped)] = _alone_and_grouped(bodies, (GROUP_SIZE,))
    assert first.tolist() == [0, 2, 3, 4] and count.tolist() == [2, 1, 1, 2]
    _assert_same(grouped, alone)


def test_the_stepper_advances_groups_as_the_compiled_loop_does():
    """somite.Episode advances robots of one body together, as vector lanes (the compiled
    loop's groups, kept between steps): stepped to the end it leaves simulate_batch's trace
    bit for bit, with groups of several robots of each shape."""
    bodies = [Body.build("worm")] * 9 + [Body.build("biped")] * 3
    rng = np.random.default_rng(3)
    graphs = [random_graph(body, 150, rng) for body in bodies]
    terrains = [hilly(1.0, 10.0, 60 + b) for b in range(len(bodies))]
    config = preset("paper", duration=0.5)
    seeds = list(range(70, 70 + len(bodies)))
    _, reference = simulate_batch(bodies, terrains, graphs, config, seeds, record=True)
    episode = Episode(graphs, terrains, config, seeds, record=True, bodies=bodies)
    assert max(group.count for group in episode._groups) > 1
    _assert_same(episode.run(), reference)


def test_groups_stepped_with_given_actuation_give_each_robots_own_numbers():
    """The stepper's groups under actuation given at each step, a robot of a group stopping
    (a NaN start) and groups of three sizes: the per-robot path's trace (step_batch), bit
    for bit."""
    bodies = [Body.build("worm")] * 5 + [Body.build("biped")] * 2
    rng = np.random.default_rng(5)
    graphs = [random_graph(body, 120, rng) for body in bodies]
    terrains = [hilly(1.0, 10.0, 30 + b) for b in range(len(bodies))]
    config = preset("paper", duration=0.5)
    system = compile_system(bodies, terrains, config.start_gap)
    system.initial_pos[2, 0, 0] = np.nan
    ctrl = compile_controllers(graphs, [b.shape.n_voxels for b in bodies])
    params, noise = pack_params(config), noise_table(config)
    seeds = np.arange(40, 40 + len(bodies), dtype=np.uint64)
    width = system.voxel_corners.shape[1]
    given = np.random.default_rng(9).uniform(-1.0, 1.0, (config.n_steps, len(bodies), width))
    traces = []
    for way in ("alone", 1, 3, GROUP_SIZE):
        trace = new_trace(len(bodies), config.n_steps, system, True)
        batch = Batch(system, ctrl, params, noise, seeds, config.n_steps, trace,
                      new_work(system, ctrl, params, np.zeros), lidar_rays(params))
        start_batch(batch)
        kept = None if way == "alone" else new_groups(
            batch, *groups(system, way, threads=1), NOT_TIMED)
        for k in range(1, config.n_steps + 1):
            if kept is None:
                step_batch(k, batch, given[k - 1])
            else:
                step_in_groups(k, batch, kept, given[k - 1], threads=1)
        traces.append(trace)
    assert traces[0].status.tolist() == [0, 0, 1, 0, 0, 0, 0]
    assert np.array_equal(traces[0].actuation[0, :-1], given[:, 0])  # in force, recorded
    for trace in traces[1:]:
        _assert_same(trace, traces[0])
