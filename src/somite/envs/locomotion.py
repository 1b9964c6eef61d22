"""``somite/Locomotion-v0``: one robot's locomotion episode as a Gymnasium environment.

An episode is a :class:`somite.Episode` of one robot with no controller of its own: each
``step(action)`` puts ``action`` in force over one control step (1/60 s) and returns what the
compiled loop computes after it, bit for bit.

- observation: the robot's sensor readings as somite normalises them, noise included, in the
  body's order (``observation_names``); the first, after ``reset``, is all zeros, as the
  compiled loop's controllers see it;
- action: one actuation a voxel in [-1, 1] (+1 contracts), in the shape's order
  (``action_names``). The action given after the observation of ``info["step"] == i`` is in
  force over [i, i + 1] / 60 s, actuation i of :class:`somite.Episode` and :class:`somite.Table`
  (docs/architecture.md, "Step 0"). The first (i = 0) is checked but not put in force: the robot
  starts at rest, as under every somite controller, which has read nothing before it. So the
  actions of an episode replay as ``somite.simulate(somite.Table(actions), body=..., ...)``
  with its terrain and noise seed, bit for bit;
- reward: the centre of mass's x-progress over the step in m/s, 0 during the paper's transient
  (the first 5 s): the mean reward over the counted steps is the episode's v_x, the fitness of
  :func:`somite.simulate` (``info["velocity"]`` holds it, computed as somite does, once the
  transient is over: before that, or after a non-finite state, ``info`` has no ``velocity``).
  The episode's return (the sum of its rewards, what Gymnasium's ``RecordEpisodeStatistics``
  reports) is therefore v_x times the counted steps, (duration - 5 s) * 60: 1500 x the fitness
  at the default 30 s, not the fitness itself;
- ``terminated`` when the robot's state went non-finite, ``truncated`` at ``duration``.

``reset(seed=)`` draws the terrain (for a ``-rnd`` distribution) and the sensor noise seed from
the environment's generator; ``options={"terrain": NAME, "noise_seed": INT}`` fixes either, e.g.
to replay ``somite simulate --terrain NAME --seed INT``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..brain.controllers import Zero
from ..errors import bad
from ..sim.config import CONTROL_HZ
from ..tasks.episode import STATUS_OK, Trace
from ..tasks.locomotion import outcomes
from ..tasks.stepper import Episode
from ..viz.frame import render_frame
from ..viz.recording import Recording
from .settings import check_seed, checked_actions, rewards, settings, velocities

RENDER_SIZE = (480, 270)
"""[px] width and height of a rendered frame."""

_GROWING = ("com", "pos", "actuation", "readings", "contact")
"""The trace's fields with a row per control step."""


def spaces_of(env_settings) -> tuple[spaces.Box, spaces.Box]:
    """(observation space, action space) of one robot."""
    low, high = env_settings.observation_bounds
    observation = spaces.Box(low, high, dtype=np.float64)
    action = spaces.Box(-1.0, 1.0, (env_settings.n_voxels,), dtype=np.float64)
    return observation, action


def frame(episode: Episode, robot: int, env_settings, terrain, size=RENDER_SIZE) -> np.ndarray:
    """(H, W, 3) uint8: robot ``robot`` of a recording ``episode`` now, drawn as ``somite
    show`` draws a frame (the steps to come are cut, so the camera sees no future)."""
    trace = episode.trace
    k = episode.k
    past = Trace(*(a[:, :k + 1] if name in _GROWING else a
                   for name, a in zip(Trace._fields, trace)))
    recording = Recording.from_trace(past, robot, env_settings.body, terrain,
                                     env_settings.config)
    step = recording.n_steps  # fewer than k if the robot went non-finite
    return np.asarray(render_frame(recording, step, *size).image)


class LocomotionEnv(gym.Env):
    """One robot walking on a terrain (see the module's docstring); keyword arguments as
    :func:`somite.envs.settings.settings`, and ``render_mode`` None or ``"rgb_array"``."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": CONTROL_HZ}

    def __init__(self, shape="worm", terrain="flat", duration=30.0, preset="paper",
                 sensors="paper", render_mode=None):
        if render_mode not in (None, "rgb_array"):
            raise bad("render_mode", render_mode, "use None or 'rgb_array' (a 'human' window "
                      "would need a display server)")
        self.settings = settings(shape, terrain, duration, preset, sensors)
        self.render_mode = render_mode
        self.observation_space, self.action_space = spaces_of(self.settings)
        self.observation_names = self.settings.observation_names
        self.action_names = self.settings.action_names
        self.terrain = None
        self._episode: Episode | None = None
        self._x_start = self._x = np.zeros(1)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=check_seed(seed))
        terrain, noise_seed = self.settings.draw(self.np_random, options)
        self.terrain = terrain
        self._episode = Episode([Zero()], terrain, self.settings.config, seeds=noise_seed,
                                record=self.render_mode is not None,
                                bodies=[self.settings.body])
        self._x = self._x_start = np.array(self._episode.com[:, 0])
        return self._observation(), self._info(np.ones(1, dtype=bool))

    def step(self, action):
        episode = self._episode
        if episode is None:
            raise bad("step", "before reset", "call reset() first")
        if episode.done or episode.status[0] != STATUS_OK:
            raise bad("step", episode.k + 1, "the episode is over: call reset()")
        action = checked_actions("action", action, self.action_space.shape)
        episode.step(action[None])
        ok = episode.status == STATUS_OK
        x = np.array(episode.com[:, 0])
        t0 = self.settings.config.transient_steps
        reward = rewards(self._x, x, ok, episode.k, t0)
        if episode.k == t0:
            self._x_start = x
        self._x = x
        terminated = not ok[0]
        truncated = episode.done and not terminated
        info = self._info(ok)
        if terminated or truncated:
            info["outcome"] = outcomes(episode.trace, self.settings.config)[0].to_dict()
        return self._observation(), float(reward[0]), terminated, truncated, info

    def render(self):
        if self.render_mode is None or self._episode is None:
            return None
        return frame(self._episode, 0, self.settings, self.terrain)

    def _observation(self) -> np.ndarray:
        return np.array(self._episode.readings[0, :self.settings.n_readings])

    def _info(self, ok: np.ndarray) -> dict:
        k = self._episode.k
        v = velocities(self._x_start, self._x, ok, k, self.settings.config.transient_steps)
        info = {"step": k, "time": k / CONTROL_HZ, "x": float(self._x[0]),
                "terrain": self.terrain.name}
        # Left out until it exists (after the transient, for a finite robot): a NaN would make
        # two identical steps' infos unequal (NaN != NaN), which Gymnasium's checker refuses.
        if np.isfinite(v[0]):
            info["velocity"] = float(v[0])
        return info


__all__ = ["LocomotionEnv", "frame", "spaces_of"]
