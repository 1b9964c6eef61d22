"""somite as Gymnasium environments (somite.envs): registration, spaces, rewards that add up to
the paper's fitness, determinism, Gymnasium's own checkers, the vector environment's equality
with single environments, and an evolved genome run as a policy."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

import somite  # noqa: E402
from somite.cli import main  # noqa: E402
from somite.envs.locomotion import LocomotionEnv  # noqa: E402
from somite.sim.config import CONTROL_HZ  # noqa: E402
from somite.tasks import stepper  # noqa: E402
from somite.tasks.episode import STATUS_NONFINITE  # noqa: E402

from .conftest import evolved, expect_error  # noqa: E402

ENV_ID = "somite/Locomotion-v0"


def _actions(rng, n_steps, shape):
    return rng.uniform(-1.0, 1.0, (n_steps, *shape))


def test_importing_somite_registers_the_env_whichever_is_imported_first():
    script = ("import {0}, {1}, gymnasium\n"
              "spec = gymnasium.spec('somite/Locomotion-v0')\n"
              "assert spec.vector_entry_point, spec\n")
    for first, second in (("somite", "gymnasium"), ("gymnasium", "somite")):
        subprocess.run([sys.executable, "-c", script.format(first, second)], check=True)
    # and "module:id" imports somite itself
    env = gym.make(f"somite:{ENV_ID}", duration=0.1)
    assert isinstance(env.unwrapped, LocomotionEnv)


def test_spaces_and_names_follow_the_body():
    env = gym.make(ENV_ID, shape="biped", duration=0.1)
    body = env.unwrapped.settings.body
    assert env.observation_space.shape == (body.n_readings,)
    assert env.action_space.shape == (10,)
    assert (env.action_space.low == -1).all() and (env.action_space.high == 1).all()
    names = env.unwrapped.observation_names
    assert len(names) == body.n_readings == len(set(names))
    # voxel by voxel, bottom row first: the biped's feet are voxels 0 (0,0) and 1 (3,0)
    assert names[0].startswith("v0(0,0).") and env.unwrapped.action_names[1] == "v1(3,0)"
    # the noise is unclipped: the bounds hold the readings plus the largest draw
    low, high = env.observation_space.low, env.observation_space.high
    assert (low < 0).all() and (high > 1).all() and np.allclose(high - 1, -low)


@pytest.mark.parametrize("kwargs, field", [
    ({"shape": "3x0"}, "shape"),
    ({"shape": 7}, "shape"),
    ({"terrain": "hilly"}, "terrain"),
    ({"terrain": "hilly-1-10-random"}, "terrain"),
    ({"duration": "long"}, "duration"),
    ({"duration": -1.0}, "duration"),
    ({"preset": "fast"}, "preset"),
    ({"sensors": "none"}, "sensors"),
    ({"sensors": "gps"}, "sensors"),
])
def test_bad_keywords_give_one_line_naming_them(kwargs, field):
    expect_error(field, lambda: gym.make(ENV_ID, **kwargs))


def test_bad_steps_and_options_give_one_line():
    # (gymnasium.make warns of an unknown mode first, and wraps "human" itself)
    expect_error("render_mode", lambda: LocomotionEnv(render_mode="ansi"))
    env = gym.make(ENV_ID, duration=1 / 30).unwrapped
    expect_error("step", lambda: env.step(np.zeros(12)))
    env.reset(seed=0)
    expect_error("action", lambda: env.step(np.zeros(11)))
    expect_error("action", lambda: env.step(np.full(12, 1.5)))  # the env's own field
    expect_error("options", lambda: env.reset(options={"noise": 3}))
    expect_error("noise_seed", lambda: env.reset(options={"noise_seed": -1}))
    env.step(np.zeros(12))
    env.step(np.zeros(12))
    expect_error("step", lambda: env.step(np.zeros(12)))
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point")
    expect_error("step", lambda: envs.step(np.zeros((2, 12))))
    envs.reset(seed=0)
    expect_error("actions", lambda: envs.step(np.zeros(12)))
    expect_error("num_envs", lambda: gym.make_vec(ENV_ID, num_envs=0,
                                                  vectorization_mode="vector_entry_point"))
    policy = somite.policy(evolved("worm", 0), n_envs=2)
    expect_error("obs", lambda: policy(np.zeros(40), True))
    expect_error("first", lambda: policy(np.zeros((2, 40)), [True] * 3))
    expect_error("genome", lambda: somite.policy("best.json"))


def test_same_seed_and_actions_give_the_same_episode_bit_for_bit():
    actions = _actions(np.random.default_rng(1), 20, (12,))

    def episode(seed):
        env = gym.make(ENV_ID, terrain="hilly-1-10-rnd", duration=20 / CONTROL_HZ)
        obs, info = env.reset(seed=seed)
        rows = [obs]
        for a in actions:
            obs, reward, *_ = env.step(a)
            rows.append(obs)
        return info["terrain"], np.array(rows)

    terrain, obs = episode(5)
    again, obs_again = episode(5)
    assert terrain == again and np.array_equal(obs, obs_again)
    other, obs_other = episode(6)
    assert other != terrain and not np.array_equal(obs, obs_other)


def test_the_mean_reward_after_the_transient_is_the_episodes_fitness():
    # 5.5 s: the first 300 steps (5 s) earn 0, the 30 after them earn the robot's v_x
    env = gym.make(ENV_ID, terrain="hilly-1-10-rnd", duration=5.5)
    env.reset(seed=2)
    rng = np.random.default_rng(2)
    rewards = []
    truncated = False
    while not truncated:
        _, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 12))
        assert not terminated
        rewards.append(reward)
    assert len(rewards) == 330
    assert rewards[:300] == [0.0] * 300 and all(r != 0 for r in rewards[300:])
    outcome = info["outcome"]
    assert info["velocity"] == outcome["velocity"]
    assert math.isclose(np.mean(rewards[300:]), outcome["velocity"], rel_tol=1e-9)


def test_an_evolved_genome_as_policy_moves_as_somite_simulate():
    genome = evolved("worm", 3)
    terrain, seed, duration = "hilly-1-10-4", 12345, 5.5
    expected = somite.simulate(genome, terrain, duration=duration, seed=seed)
    env = gym.make(ENV_ID, shape=genome.body.shape, terrain="flat", duration=duration)
    policy = somite.policy(genome)
    obs, info = env.reset(options={"terrain": terrain, "noise_seed": seed})
    rewards = []
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs, info["step"] == 0))
        rewards.append(reward)
        done = terminated or truncated
    assert truncated and info["velocity"] == expected.velocity
    assert info["outcome"] == expected.to_dict()  # every number of the episode, bit for bit
    assert math.isclose(np.mean(rewards[300:]), expected.velocity, rel_tol=1e-9)


@pytest.mark.parametrize("shape, terrain", [
    ("worm", "flat"), ("biped", "hilly-1-10-rnd"), ("2x2", "steppy-1-10-rnd"),
    ("111/010", "uphill-rnd"),
])
def test_gymnasiums_check_env_passes(shape, terrain):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, shape=shape, terrain=terrain, duration=0.2)
    check_env(env.unwrapped)


@pytest.mark.parametrize("duration", [6.0, 30.0])
def test_gymnasiums_check_env_passes_past_the_transient(duration):
    # Over 5 s the episode has a transient, before which v_x does not exist yet: a NaN in
    # info made two equal steps unequal to the checker.
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, duration=duration)
    check_env(env.unwrapped)
    _, info = env.reset(seed=0)
    assert "velocity" not in info
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point",
                        duration=duration)
    _, infos = envs.reset(seed=0)
    assert not infos["_velocity"].any() and (infos["velocity"] == 0).all()


def test_an_env_sequence_replays_bit_for_bit_through_table_episode_and_the_cli(
        tmp_path, capsys):
    # A user's sequence found in the env, its first action not zero (the one the robot never
    # feels: actuation 0 is 0 everywhere, docs/architecture.md "Step 0").
    terrain, seed, duration = "hilly-1-10-3", 77, 5.5
    env = gym.make(ENV_ID, terrain="flat", duration=duration)
    obs, info = env.reset(options={"terrain": terrain, "noise_seed": seed})
    actions = _actions(np.random.default_rng(5), 330, (12,))
    for a in actions:
        obs, reward, terminated, truncated, info = env.step(a)
    assert truncated and info["step"] == 330
    body = env.unwrapped.settings.body
    table = somite.simulate(somite.Table(actions), body=body, terrain=terrain,
                            duration=duration, seed=seed)
    assert info["outcome"] == table.to_dict()  # every number, bit for bit
    assert info["velocity"] == table.velocity
    config = env.unwrapped.settings.config
    by_table = somite.Episode([somite.Table(actions)], terrain, config, seeds=seed,
                              bodies=[body], record=True)
    by_table.run()
    given = somite.Episode([somite.Zero()], terrain, config, seeds=seed, bodies=[body],
                           record=True)
    for a in actions:
        given.step(a[None])
    assert np.array_equal(given.trace.com, by_table.trace.com)
    # (the last row is a decision for a step that never comes: the table's row 0)
    assert np.array_equal(given.trace.actuation[:, :-1], by_table.trace.actuation[:, :-1])
    assert (given.trace.actuation[0, 0] == 0).all()  # the first action was not in force
    assert np.array_equal(given.trace.actuation[0, 1:-1], actions[1:])
    # The fifth entry point: the same actions as a CSV file (17 digits: every double exactly).
    csv = tmp_path / "actions.csv"
    np.savetxt(csv, actions, delimiter=",", fmt="%.17g")
    assert main(["simulate", "--actions", str(csv), "--shape", body.shape.grid_string(),
                 "--terrain", terrain, "--duration", str(duration), "--seed", str(seed),
                 "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = {k: None if isinstance(v, float) and v != v else v  # JSON's null
                for k, v in info["outcome"].items()}
    assert {key: report[key] for key in expected} == expected


def test_gymnasiums_env_checker_passes_with_the_render_check():
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID, shape="biped", terrain="hilly-1-10-rnd", duration=0.2,
                   render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)


def test_render_draws_the_robot_as_somite_show_does():
    env = gym.make(ENV_ID, duration=0.5, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    assert first.shape == (270, 480, 3) and first.dtype == np.uint8
    for _ in range(20):
        env.step(np.ones(12))
    later = env.render()
    assert not np.array_equal(first, later)
    # a contracted voxel is drawn red (somite.viz.frame.area_colour), none is at the start
    red = (later[..., 0] > 180) & (later[..., 1] < 90) & (later[..., 2] < 90)
    assert red.sum() > 50 > ((first[..., 0] > 180) & (first[..., 1] < 90)).sum()


def test_the_vector_env_steps_one_batch_per_step_with_single_envs_numbers(monkeypatch):
    n, steps = 3, 12
    duration = steps / CONTROL_HZ
    calls = []
    step = stepper.Episode.step

    def counted(self, actuation=None):
        if self.n_robots > 1:  # not the single envs'
            calls.append(self.n_robots)
        return step(self, actuation)

    monkeypatch.setattr(stepper.Episode, "step", counted)
    envs = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point",
                        terrain="hilly-1-10-rnd", duration=duration)
    assert envs.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    singles = [gym.make(ENV_ID, terrain="hilly-1-10-rnd", duration=duration) for _ in range(n)]
    actions = _actions(np.random.default_rng(4), steps + 2, (n, 12))
    obs, infos = envs.reset(seed=7)
    single_obs = [env.reset(seed=7 + i)[0] for i, env in enumerate(singles)]
    assert len(set(envs.unwrapped.terrains)) == n  # a terrain each
    assert np.array_equal(obs, np.array(single_obs))
    for t in range(steps):
        obs, reward, terminated, truncated, infos = envs.step(actions[t])
        for i, env in enumerate(singles):
            o, r, te, tr, info = env.step(actions[t, i])
            assert np.array_equal(obs[i], o) and reward[i] == r
            assert (terminated[i], truncated[i]) == (te, tr)
            assert infos["step"][i] == info["step"] and infos["x"][i] == info["x"]
    assert truncated.all() and calls == [n] * steps
    # NEXT_STEP: the next step starts new episodes, ignoring its actions
    obs, reward, terminated, truncated, infos = envs.step(actions[steps])
    assert (reward == 0).all() and not (terminated | truncated).any()
    assert (infos["step"] == 0).all() and calls == [n] * steps
    assert np.array_equal(obs, np.array([env.reset()[0] for env in singles]))
    obs, *_ = envs.step(actions[steps + 1])
    assert calls == [n] * (steps + 1)
    assert np.array_equal(obs, np.array([env.step(actions[steps + 1, i])[0]
                                         for i, env in enumerate(singles)]))


def test_a_genome_policy_runs_in_the_vector_env_as_in_single_envs():
    genome = evolved("biped", 5)
    n = 2
    kwargs = {"shape": genome.body.shape, "terrain": "hilly-1-10-rnd", "duration": 0.5}
    envs = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    policy = somite.policy(genome, n_envs=n)
    obs, infos = envs.reset(seed=3)
    for _ in range(30):
        obs, *_, infos = envs.step(policy(obs, infos["step"] == 0))
    for i in range(n):
        env = gym.make(ENV_ID, **kwargs)
        one = somite.policy(genome)
        o, info = env.reset(seed=3 + i)
        for _ in range(30):
            o, *_, info = env.step(one(o, info["step"] == 0))
        assert info["velocity"] == infos["velocity"][i]
        assert np.array_equal(o, obs[i])


def test_a_sub_env_that_blows_up_restarts_alone_while_the_others_go_on(monkeypatch):
    # A non-finite state is rare and hard to provoke: robot 1's is marked so after step 3.
    n, steps = 3, 10
    step = stepper.Episode.step

    def blowing_up(self, actuation=None):
        step(self, actuation)
        if self.n_robots == n and self.k == 3:
            self._trace.status[1] = STATUS_NONFINITE
        return self

    monkeypatch.setattr(stepper.Episode, "step", blowing_up)
    envs = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point",
                        terrain="hilly-1-10-rnd", duration=steps / CONTROL_HZ)
    envs.reset(seed=1)
    single = gym.make(ENV_ID, terrain="hilly-1-10-rnd", duration=steps / CONTROL_HZ)
    single.reset(seed=2)
    actions = _actions(np.random.default_rng(0), steps, (n, 12))
    for t in range(3):
        _, reward, terminated, truncated, _ = envs.step(actions[t])
    assert list(terminated) == [False, True, False] and reward[1] == 0
    o, _ = single.reset()  # env 1's next episode
    obs, reward, terminated, truncated, infos = envs.step(actions[3])
    assert list(infos["step"]) == [4, 0, 4] and np.array_equal(obs[1], o)
    for t in range(4, steps):
        obs, reward, terminated, truncated, infos = envs.step(actions[t])
        o, r, *_ = single.step(actions[t, 1])
        assert np.array_equal(obs[1], o) and reward[1] == r
    assert list(truncated) == [True, False, True] and list(infos["step"]) == [10, 6, 10]
    assert len(envs.unwrapped._batches) == 2


def test_the_random_search_example_runs_on_a_tiny_budget(capsys):
    import runpy
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "gym_random_search.py"
    example = runpy.run_path(str(path))
    result = example["main"](["--iterations", "2", "--directions", "2", "--duration", "0.5"])
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and lines[0].startswith("iteration 0: v_x of theta ")
    assert len(result["velocities"]) == 2 and all(map(math.isfinite, result["velocities"]))
    assert result["theta"].shape == (12, 40 + 3) and result["theta"].any()


def test_the_readmes_gymnasium_block_runs():
    from .test_readme import _block

    names: dict = {}
    exec(compile(_block("gym", "python"), "README.md", "exec"), names)
    assert names["info"]["step"] == 360 and not names["truncated"].any()
    assert names["info"]["velocity"] == names["info"]["outcome"]["velocity"]
    assert names["obs"].shape == (64, 40) and names["rewards"].shape == (64,)


def test_the_benchmark_prints_the_json_that_benchmarks_md_quotes():
    from .test_benchmarks import run_script

    out = run_script("gym_env.py", "--duration", "0.1", "--sizes", "2", "--repeats", "1")
    assert out["control_steps"] == 6 and out["single_env"]["steps_per_second"] > 0
    [row] = out["by_robots"]
    assert row["robots"] == 2
    assert set(row["robot_control_steps_per_second"]) == {"vector_env", "episode_step",
                                                          "compiled_loop"}
