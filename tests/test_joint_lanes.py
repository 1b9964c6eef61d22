"""The joints' passes over LANES robots at once (somite.sim.joint_lanes) give each robot exactly
the numbers of the one-robot passes (somite.sim.physics), from states chosen to reach every
choice a joint makes: rope limits active and not, a spring whose ends meet (no direction),
large and tiny velocities, warm-start impulses of both signs."""

from __future__ import annotations

import numpy as np
import pytest

from somite.sim import joint_lanes as jl
from somite.sim import physics as ph
from somite.sim.body import Body
from somite.sim.config import SimConfig, pack_params
from somite.sim.robot import robot_body, robot_view
from somite.sim.system import compile_system
from somite.sim.terrain import parse_terrain

PASSES = 3


def _states(robot, seed):
    """LANES robots' positions, velocities, rest lengths and warm-start impulses."""
    rng = np.random.default_rng(seed)
    lanes, p = jl.LANES, robot.n_points
    pos = np.empty((lanes, p, 3))
    pos[:, :, :2] = rng.normal(0.0, 3.0, (lanes, p, 2))
    pos[:, :, 2] = rng.uniform(-np.pi, np.pi, (lanes, p))
    # Lane 1: every block on one spot, so every rope limit is active; lane 2: spread out.
    pos[1, :, :2] = pos[1, 0, :2]
    pos[2, :, :2] *= 10.0
    # Lane 3: spring 0's anchors meet, so it has no direction.
    a, b = robot.ends[0]
    cos, sin = np.cos(pos[3, :, 2]), np.sin(pos[3, :, 2])
    rax, ray = ph.rotated(robot.anchor[0, 0], robot.anchor[0, 1], cos[a], sin[a])
    rbx, rby = ph.rotated(robot.anchor[0, 2], robot.anchor[0, 3], cos[b], sin[b])
    pos[3, b, 0] = pos[3, a, 0] + rax - rbx
    pos[3, b, 1] = pos[3, a, 1] + ray - rby
    vel = rng.normal(0.0, 1.0, (lanes, p, 3)) * 10.0 ** rng.integers(-8, 3, (lanes, p, 1))
    rest = rng.uniform(0.1, 3.0, (lanes, robot.n_springs))
    impulse = rng.normal(0.0, 5.0, (lanes, 3))
    return pos, vel, rest, impulse


def _orders(robot):
    """The lanes' order of the springs, rope limits and welds (not their index order: the
    one-robot passes go in index order, so the tests below check that the orders give the same
    bits)."""
    orders = [jl.exact_order(ends, robot.n_points)
              for ends in (robot.ends, robot.rope_ends, robot.weld_ends)]
    assert all((o != np.arange(o.shape[0])).any() for o in orders)
    return orders


@pytest.mark.parametrize("shape", ["worm", "biped"])
@pytest.mark.parametrize("seed", [0, 1])
def test_lanes_give_each_robot_the_one_robot_passes_numbers(shape, seed):
    params = pack_params(SimConfig())
    system = compile_system([Body.build(shape)], [parse_terrain("flat")])
    robot = robot_view(system, 0, params)
    pos, vel, rest, impulse = _states(robot, seed)
    stale = np.random.default_rng(seed + 100).uniform(0.1, 1.0, (jl.LANES, robot.n_ropes, 3))
    width, p = jl.LANES, robot.n_points
    lanes = jl.Lanes(
        robot.ends.copy(), robot.anchor.copy(), robot.rope_ends.copy(), robot.weld_ends.copy(),
        robot.weld_anchor.copy(), robot.inv_mass.copy(), robot.inv_inertia.copy(),
        np.empty((p, 3, width)), np.empty((p, 3, width)), np.empty((p, width)),
        np.empty((p, width)), np.ascontiguousarray(rest.T),
        np.zeros((robot.n_springs, ph.N_SPRING_COLUMNS, width)),
        np.zeros((robot.n_ropes, ph.N_ROPE_COLUMNS, width)),
        np.zeros((robot.n_welds, ph.N_WELD_COLUMNS, width)), *_orders(robot))
    alone = []
    for g in range(width):
        scratch = robot_body(robot)
        scratch.rest[:] = rest[g]
        scratch.cos[:] = np.cos(pos[g, :, 2])
        scratch.sin[:] = np.sin(pos[g, :, 2])
        for work, column, kind in ((scratch.spring, ph.J_IMPULSE, 0),
                                   (scratch.rope, ph.R_IMPULSE, 1), (scratch.weld, ph.W_JX, 2)):
            work[:] = 0.0
            work[:, column] = impulse[g, kind]
        scratch.weld[:, ph.W_JY] = -impulse[g, 2]
        scratch.weld[:, ph.W_JZ] = impulse[g, 0]
        # What an earlier active step left in a rope limit's row: never read while it is
        # inactive, so the lanes must not let it through either.
        scratch.rope[:, [ph.R_NX, ph.R_NY, ph.R_MASS]] = stale[g]
        lanes.spring[:, :, g] = scratch.spring
        lanes.rope[:, :, g] = scratch.rope
        lanes.weld[:, :, g] = scratch.weld
        own_vel = vel[g].copy()
        jl.take(lanes, g, pos[g], own_vel, scratch.cos, scratch.sin)
        ph.start_springs(robot, scratch, pos[g], own_vel, params)
        ph.start_ropes(robot, scratch, pos[g], own_vel)
        ph.start_welds(robot, scratch, own_vel)
        for _ in range(PASSES):
            ph.solve_springs(robot, scratch, own_vel)
            ph.solve_ropes(robot, scratch, own_vel)
            ph.solve_welds(robot, scratch, own_vel)
        alone.append((own_vel, scratch))
    jl.start_joints(lanes, params)
    for _ in range(PASSES):
        jl.solve_joints(lanes)
    active = np.array([s.rope[:, ph.R_ACTIVE] for _, s in alone])
    assert active[1].all() and not active[2].any()  # both kinds of rope limit were met
    assert alone[3][1].spring[0, ph.J_NX] == alone[3][1].spring[0, ph.J_NY] == 0.0
    for g, (own_vel, scratch) in enumerate(alone):
        assert np.array_equal(lanes.vel[:, :, g], own_vel, equal_nan=True), g
        assert np.array_equal(lanes.spring[:, :, g], scratch.spring, equal_nan=True), g
        assert np.array_equal(lanes.weld[:, :, g], scratch.weld, equal_nan=True), g
        live = scratch.rope[:, ph.R_ACTIVE] != 0.0  # an inactive limit's row is never read
        assert np.array_equal(lanes.rope[:, ph.R_ACTIVE, g], scratch.rope[:, ph.R_ACTIVE])
        assert np.array_equal(lanes.rope[live, :, g], scratch.rope[live], equal_nan=True), g
        assert np.array_equal(lanes.rope[~live, ph.R_IMPULSE, g], scratch.rope[~live,
                                                                           ph.R_IMPULSE])


@pytest.mark.parametrize("shape", ["worm", "biped"])
@pytest.mark.parametrize("seed", [0, 1])
def test_lanes_move_and_position_passes_match_the_one_robot_passes(shape, seed):
    """The move and the rope limits' and welds' position passes in lanes: each busy lane ends
    where the robot's own passes take it, rotations and "holds" included; a lane marked DONE
    keeps its bodies (a robot whose passes are over must not move while others go on)."""
    params = pack_params(SimConfig())
    system = compile_system([Body.build(shape)], [parse_terrain("flat")])
    robot = robot_view(system, 0, params)
    pos, vel, _, _ = _states(robot, seed)
    # Lane 4: bodies spun past +-pi against their weld partners (the angle wraps); lane 5:
    # fast enough for the move's limits on translation and rotation.
    pos[4, :, 2] = np.where(np.arange(robot.n_points) % 2, 3.1, -3.1)
    vel[5] *= 1e4
    width, p = jl.LANES, robot.n_points
    lanes = jl.Lanes(
        robot.ends.copy(), robot.anchor.copy(), robot.rope_ends.copy(), robot.weld_ends.copy(),
        robot.weld_anchor.copy(), robot.inv_mass.copy(), robot.inv_inertia.copy(),
        np.empty((p, 3, width)), np.empty((p, 3, width)), np.empty((p, width)),
        np.empty((p, width)), np.zeros((robot.n_springs, width)),
        np.zeros((robot.n_springs, ph.N_SPRING_COLUMNS, width)),
        np.zeros((robot.n_ropes, ph.N_ROPE_COLUMNS, width)),
        np.zeros((robot.n_welds, ph.N_WELD_COLUMNS, width)), *_orders(robot))
    flags = np.zeros((width, 4), dtype=np.bool_)
    flags[6, jl.DONE] = True
    alone = []
    for g in range(width):
        scratch = robot_body(robot)
        own_pos, own_vel = pos[g].copy(), vel[g].copy()
        jl.take(lanes, g, own_pos, own_vel, scratch.cos, scratch.sin)
        ph.positions(robot, scratch, own_pos, own_vel, params)
        held = []
        for _ in range(PASSES):
            held.append((ph.fix_ropes(robot, own_pos),
                         ph.fix_welds(robot, own_pos, scratch.cos, scratch.sin)))
        alone.append((own_pos, own_vel, scratch, held))
    jl.move(lanes.pos, lanes.vel, lanes.cos, lanes.sin, params.dt)
    moved = lanes.pos.copy()
    held = []
    for _ in range(PASSES):
        jl.fix_joints(lanes, flags)
        held.append(flags[:, [jl.ROPES_HELD, jl.WELDS_HELD]].copy())
    assert not all(h for _, _, _, hs in alone for pair in hs for h in pair)  # passes worked
    for g, (own_pos, own_vel, scratch, own_held) in enumerate(alone):
        assert np.array_equal(lanes.vel[:, :, g], own_vel, equal_nan=True), g
        if g == 6:
            assert np.array_equal(lanes.pos[:, :, g], moved[:, :, g], equal_nan=True)
            continue
        assert np.array_equal(lanes.pos[:, :, g], own_pos, equal_nan=True), g
        assert np.array_equal(lanes.cos[:, g], scratch.cos, equal_nan=True), g
        assert np.array_equal(lanes.sin[:, g], scratch.sin, equal_nan=True), g
        assert [tuple(h[g]) for h in held] == own_held, g
