"""What the Gymnasium environments cost: env steps per second against the compiled loop.

Worms on hilly terrains (``hilly-1-10-rnd``, a terrain each), uniform random actions drawn
beforehand (the policy's cost is left out), ``--duration`` s episodes. For one env and for the
vector env (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``) at each
``--sizes`` N: robot-control-steps per second (one env step of N robots is N of them), over a
whole episode from ``reset``. Against, at the same N, terrains and actions: ``somite.Episode``
stepped with the actions (what the vector env calls once a step) and the compiled loop
(``simulate_batch``, the cpu backend, the same actions replayed by a ``Table`` controller); the
single env against ``somite.Episode`` of one robot.
The best of ``--repeats`` rounds, the workloads in turn within a round, after a throw-away
first round (compiling, or loading Numba's cache).
Threads: Numba's (``NUMBA_NUM_THREADS``). Prints JSON.

    python benchmarks/gym_env.py [--duration 10] [--sizes 16 64 256] [--repeats 2]
"""

from __future__ import annotations

import argparse
import json
import os

import gymnasium as gym
import numba
import numpy as np

import somite  # noqa: F401  (registers somite/Locomotion-v0)
from somite.bench import timed
from somite.brain.controllers import Table, Zero
from somite.tasks.locomotion import simulate_batch
from somite.tasks.stepper import Episode

ENV_ID = "somite/Locomotion-v0"


def _best(works: dict, repeats: int) -> dict:
    """The best time of each of ``works`` over ``repeats`` rounds, run in turn within a round
    (a machine whose load drifts slows them alike), after a throw-away first round (compiling,
    or loading Numba's cache)."""
    for work in works.values():
        work()
    times = {name: [] for name in works}
    for _ in range(repeats):
        for name, work in works.items():
            times[name].append(timed(work))
    return {name: min(t) for name, t in times.items()}


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    kwargs = {"shape": "worm", "terrain": "hilly-1-10-rnd", "duration": args.duration}
    rng = np.random.default_rng(0)

    env = gym.make(ENV_ID, **kwargs)
    n_steps = env.unwrapped.settings.config.n_steps
    one = rng.uniform(-1.0, 1.0, (n_steps, 12))

    def single():
        env.reset(seed=0)
        for action in one:
            env.step(action)

    env_settings = env.unwrapped.settings

    def single_episode():
        stepped = Episode([Zero()], env.unwrapped.terrain, env_settings.config,
                          bodies=[env_settings.body])
        for action in one:
            stepped.step(action[None])

    single_times = _best({"env": single, "episode": single_episode}, args.repeats)
    seconds, episode_seconds = single_times["env"], single_times["episode"]
    result = {
        "benchmark": "gymnasium env steps per second (robot-control-steps per second)",
        "shape": "worm", "terrain": kwargs["terrain"], "duration_s": args.duration,
        "control_steps": n_steps, "threads": numba.get_num_threads(),
        "cpus": os.cpu_count(), "repeats": args.repeats,
        "single_env": {"steps_per_second": round(n_steps / seconds),
                       "episode_steps_per_second": round(n_steps / episode_seconds),
                       "env_us_per_step_over_episode": round(
                           1e6 * (seconds - episode_seconds) / n_steps, 1)},
    }
    result["by_robots"] = [_by_robots(n, n_steps, rng, kwargs, args.repeats)
                           for n in args.sizes]
    return result


def _by_robots(n: int, n_steps: int, rng, kwargs: dict, repeats: int) -> dict:
    """The vector env, Episode.step and the compiled loop, each over n robots."""
    envs = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    actions = rng.uniform(-1.0, 1.0, (n_steps, n, 12))

    def vector():
        envs.reset(seed=0)
        for step_actions in actions:
            envs.step(step_actions)

    envs.reset(seed=0)
    terrains = list(envs.unwrapped.terrains)
    settings = envs.unwrapped.settings
    body, config = settings.body, settings.config

    def episode():
        stepped = Episode([Zero()] * n, terrains, config, bodies=[body] * n)
        for step_actions in actions:
            stepped.step(step_actions)

    # Row k is what control step k decides, in force over step k + 1, as the env's
    # actions[k] (but step 1's actuation: 0 in the compiled loop).
    tables = [Table(actions[:, b]) for b in range(n)]

    def compiled():
        simulate_batch([body] * n, terrains, tables, config)

    times = _best({"vector_env": vector, "episode_step": episode, "compiled_loop": compiled},
                  repeats)
    rate = {k: round(n * n_steps / v) for k, v in times.items()}
    row = {
        "robots": n,
        "robot_control_steps_per_second": rate,
        "vector_env_us_per_robot_step_over_compiled_loop": round(
            1e6 * (times["vector_env"] - times["compiled_loop"]) / (n * n_steps), 2),
        "vector_env_cost_x_compiled_loop": round(times["vector_env"] / times["compiled_loop"],
                                                 2),
        "vector_env_cost_x_episode_step": round(times["vector_env"] / times["episode_step"],
                                                2),
    }
    envs.close()
    return row


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
