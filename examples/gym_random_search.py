"""Random search over a linear policy on somite's vector Gymnasium environment.

The policy is a = tanh(W [obs, sin 2 pi f t, cos 2 pi f t] + b): one row of W and b a voxel, a
column of W a sensor reading (``env.observation_names``) or one of the two clock features (a
memoryless policy of the readings alone hardly starts a gait: the clock gives it a rhythm,
which the readings can shape). Each iteration draws ``--directions`` random directions d and runs
the current parameters and each theta + s d and theta - s d as one robot each of one vector
environment, a whole episode (the robots of a vector env are stepped together, one compiled
call a step); the episode's return (mean reward after the 5 s transient) is its v_x [m/s].
Parameters move along the directions, weighted by how much better + did than - (basic random
search, Mania et al. 2018). Needs gymnasium (``pip install somite[gym]``), nothing else.

    python examples/gym_random_search.py [--iterations 20] [--directions 8] [--duration 10]
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import somite  # noqa: F401  (registers somite/Locomotion-v0 with gymnasium)

CLOCK_HZ = 2.0
"""The clock features' frequency."""


def episode_velocities(envs, thetas: np.ndarray, seed: int) -> np.ndarray:
    """Run one episode with robot i driven by the linear policy ``thetas[i]``; each robot's v_x
    (its mean reward after the transient; over the whole episode when it is that short)."""
    obs, info = envs.reset(seed=seed)
    transient = envs.unwrapped.settings.config.transient_steps
    weights, biases = thetas[:, :, :-1], thetas[:, :, -1]
    total = np.zeros(envs.num_envs)
    counted = np.zeros(envs.num_envs)
    done = np.zeros(envs.num_envs, dtype=bool)
    while not done.all():
        phase = 2 * np.pi * CLOCK_HZ * info["time"]
        features = np.column_stack([obs, np.sin(phase), np.cos(phase)])
        actions = np.tanh(np.einsum("nvr,nr->nv", weights, features) + biases)
        obs, reward, terminated, truncated, info = envs.step(actions)
        live = ~done
        total[live] += reward[live]
        # the transient's steps earn exactly 0; after it every step counts
        counted[live] += info["step"][live] > transient
        done |= terminated | truncated
    return total / counted


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--directions", type=int, default=8)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--shape", default="worm")
    parser.add_argument("--terrain", default="flat")
    parser.add_argument("--step-size", type=float, default=0.2)
    parser.add_argument("--noise", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    # Robot 0 runs theta itself, robots 1..2K theta +- s d.
    envs = gym.make_vec("somite/Locomotion-v0", num_envs=1 + 2 * args.directions,
                        vectorization_mode="vector_entry_point", shape=args.shape,
                        terrain=args.terrain, duration=args.duration)
    n_voxels = envs.single_action_space.shape[0]
    n_readings = envs.single_observation_space.shape[0]
    rng = np.random.default_rng(args.seed)
    theta = np.zeros((n_voxels, n_readings + 3))  # the readings, the clock, the bias
    history = []
    for iteration in range(args.iterations):
        directions = rng.standard_normal((args.directions, *theta.shape))
        thetas = np.concatenate([theta[None], theta + args.noise * directions,
                                 theta - args.noise * directions])
        # Every candidate meets the same terrains and noise: a fair comparison.
        v = episode_velocities(envs, thetas, seed=args.seed + iteration)
        plus, minus = v[1:1 + args.directions], v[1 + args.directions:]
        spread = np.std(np.concatenate([plus, minus])) or 1.0
        theta = theta + args.step_size / (args.directions * spread) * np.einsum(
            "k,kvr->vr", plus - minus, directions)
        history.append(float(v[0]))
        print(f"iteration {iteration}: v_x of theta {v[0]:+.3f} m/s, "
              f"best candidate {np.max(v):+.3f} m/s")
    envs.close()
    return {"velocities": history, "theta": theta}


if __name__ == "__main__":
    main()
