"""What the Gymnasium environments, an Episode and a Terrain are given (issue 71): checked
before it is converted or used, refused in one somite error naming the field."""

from __future__ import annotations

import threading

import gymnasium as gym
import numpy as np
import pytest

from somite.brain.controllers import Zero
from somite.envs import ENV_ID
from somite.envs.locomotion import LocomotionEnv
from somite.envs.vector import LocomotionVectorEnv
from somite.errors import SomiteError, SomiteTypeError
from somite.sim.body import Body
from somite.sim.config import preset
from somite.sim.terrain import Terrain, parse_terrain
from somite.tasks.stepper import Episode

WORM = Body.build("worm")


@pytest.mark.parametrize("terrain", ["hilly-1-10-10000", "hilly-1-10-10999", "hilly-1-10-20005"])
def test_the_env_refuses_held_out_terrains_as_evolve_does(terrain):
    with pytest.raises(SomiteError, match=f"^terrain='{terrain}': a validation or fresh"):
        LocomotionEnv(terrain=terrain, duration=0.1)
    env = LocomotionEnv(terrain="hilly-1-10-3", duration=0.1)
    for given in (terrain, parse_terrain(terrain)):
        with pytest.raises(SomiteError, match="^terrain="):
            env.reset(options={"terrain": given})
    with pytest.raises(SomiteTypeError, match="^options="):
        env.reset(options=[("terrain", "flat")])
    with pytest.raises(SomiteTypeError, match="^terrain="):
        env.reset(options={"terrain": 3})
    for seed in (-1, "1", 1.5):
        with pytest.raises(SomiteError, match="^seed="):
            env.reset(seed=seed)


@pytest.fixture(scope="module")
def env():
    env = LocomotionEnv(duration=0.5)
    env.reset(seed=0)
    return env


V = WORM.shape.n_voxels


@pytest.mark.parametrize("action, why", [
    ("0.5", "expected an array of numbers"),
    (["0.5"] * V, "not values of dtype <U3"),
    ([True] * V, "not values of dtype bool"),
    ([0.5j] * V, "not values of dtype complex128"),
    ([[0.1], [0.1, 0.2]], "expected an array of numbers"),
    ([0.1] * (V - 1), f"must have shape ({V},)"),
    ([0.1, 0.1, np.nan] + [0.1] * (V - 3), "in [-1, 1]"),
    ([0.1, 0.1, 2.0] + [0.1] * (V - 3), "in [-1, 1]"),
])
def test_a_bad_action_is_refused_before_it_is_converted(env, action, why):
    k = env.unwrapped._episode.k
    with pytest.raises(SomiteError) as info:
        env.step(action)
    assert str(info.value).startswith("action=") and why in str(info.value)
    assert env.unwrapped._episode.k == k  # not stepped
    env.step(np.zeros(V, dtype=np.float32))  # a real action of any float or int dtype is


def test_num_envs_is_bounded_before_allocating_and_takes_numpy_integers():
    with pytest.raises(SomiteError, match="^num_envs=1000000000: must be at most"):
        LocomotionVectorEnv(10**9, duration=0.1)
    for wrong in (2.0, True, "2"):
        with pytest.raises(SomiteTypeError, match="^num_envs="):
            LocomotionVectorEnv(wrong, duration=0.1)
    envs = LocomotionVectorEnv(np.int64(2), duration=0.1)
    assert envs.num_envs == 2 and type(envs.num_envs) is int
    for seed in ([0, -1], -1, "ab"):
        with pytest.raises(SomiteError, match="^seed="):
            envs.reset(seed=seed)
    envs.reset(seed=0)
    with pytest.raises(SomiteError, match="^actions="):
        envs.step([["1"] * V] * 2)


def test_an_unsupported_render_mode_is_refused_through_gymnasium_too():
    with pytest.raises(SomiteError, match="^render_mode='human'"):
        gym.make(ENV_ID, duration=0.1, render_mode="human")  # not a pygame window
    assert gym.make(ENV_ID, duration=0.1, render_mode="rgb_array_list").render_mode \
        == "rgb_array_list"


def test_an_episode_stepped_from_two_threads_at_once_refuses_the_second():
    config = preset("paper", duration=1.0)
    episode = Episode([Zero()], "hilly-1-10-3", config, bodies=[WORM])
    with episode._stepping:  # another thread is in a step: this one is refused, not run
        with pytest.raises(SomiteError, match="^step=1: another thread is stepping"):
            episode.step()
    refused = []

    def stepper():
        while not episode.done:
            try:
                episode.step()
            except SomiteError as error:
                refused.append(str(error))

    threads = [threading.Thread(target=stepper) for _ in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    alone = Episode([Zero()], "hilly-1-10-3", config, bodies=[WORM])
    alone.run()
    assert np.array_equal(episode.trace.com, alone.trace.com)  # the same trajectory
    assert all("another thread" in r or "control steps" in r for r in refused)


def test_a_terrain_is_read_only_and_checked():
    terrain = parse_terrain("hilly-1-10-3")
    with pytest.raises(ValueError, match="read-only"):
        terrain.ys[5] = np.nan
    xs, ys = np.array([0.0, 10.0, 20.0]), np.array([1.0, 0.0, 1.0])
    own = Terrain("mine", xs, ys)
    xs[1] = 5.0  # the caller's array stays its own
    assert own.xs[1] == 10.0 and xs.flags.writeable
    for bad_xs, bad_ys, field in [([0.0, 1.0], [0.0, np.nan], "terrain.ys=nan"),
                                  ([0.0, 0.0], [0.0, 0.0], "terrain.xs=0.0"),
                                  ([0.0, 1.0, 2.0], [0.0, 1.0], "terrain.ys=")]:
        with pytest.raises(SomiteError, match=f"^{field}"):
            Terrain("bad", bad_xs, bad_ys)
