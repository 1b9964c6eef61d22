"""``somite/Locomotion-v0`` as a vector environment: N robots stepped by one compiled batch call.

``gymnasium.make_vec("somite/Locomotion-v0", num_envs=N, vectorization_mode=
"vector_entry_point", ...)`` builds a :class:`LocomotionVectorEnv`: the N robots are the rows
of one :class:`somite.Episode`, and ``step(actions)`` is one ``Episode.step`` for all of them,
not N Python environments. Sub-environment i gives the numbers that a single environment
(:class:`~somite.envs.locomotion.LocomotionEnv`) reset with seed ``seed + i`` gives for the
same actions, bit for bit (tested): each sub-environment draws its terrain and noise seed from
its own generator, so a ``-rnd`` distribution gives each its own terrain.

Autoreset: Gymnasium 1.x's ``NEXT_STEP`` mode (``metadata["autoreset_mode"]``). A step that
returns ``terminated`` or ``truncated`` for sub-environment i is followed by one whose action
for i is ignored and which returns i's new episode's first observation, reward 0 and neither
flag. Every episode lasts ``duration``, so normally all N end at the same step and the next
step starts one new batch of N. A robot whose state goes non-finite (``terminated``) ends
early: its new episode starts at the next step in a batch of its own, which is stepped beside
the others (one more ``Episode.step`` per step until that batch ends: such batches are rare).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..brain.controllers import Zero
from ..errors import bad, bad_type
from ..sim.config import CONTROL_HZ
from ..tasks.episode import STATUS_OK
from ..tasks.stepper import Episode
from .locomotion import spaces_of
from .settings import (
    check_num_envs,
    check_seed,
    checked_actions,
    rewards,
    settings,
    velocities,
)


def _seeds(value) -> list:
    """A list of seeds (each None or a non-negative integer), else a one-line error."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
        raise bad_type("seed", value, "None, an integer or a list of them, one per env")
    return [check_seed(s) for s in value]


@dataclass
class _Batch:
    """An :class:`Episode` whose robot ``r`` is sub-environment ``envs[r]`` while ``member[r]``
    (its episode's last observation not yet replaced by a new episode's); ``running[r]``: not
    ended either."""

    episode: Episode
    envs: np.ndarray
    member: np.ndarray
    running: np.ndarray
    x: np.ndarray  # centre of mass x after the last step [m]
    x_start: np.ndarray  # ... after the transient's last step


class LocomotionVectorEnv(VectorEnv):
    """``num_envs`` robots of the same body on terrains of the same distribution (keyword
    arguments as :func:`somite.envs.settings.settings`), stepped together."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int, shape="worm", terrain="flat", duration=30.0,
                 preset="paper", sensors="paper", render_mode=None):
        num_envs = check_num_envs(num_envs)  # before the spaces and episodes are allocated
        if render_mode is not None:
            raise bad("render_mode", render_mode, "the vector environment does not render; "
                      "render a single environment")
        self.settings = settings(shape, terrain, duration, preset, sensors)
        self.num_envs = num_envs
        self.render_mode = None
        self.single_observation_space, self.single_action_space = spaces_of(self.settings)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_names = self.settings.observation_names
        self.action_names = self.settings.action_names
        self.terrains: list = [None] * num_envs
        self._rngs: list[np.random.Generator] | None = None
        self._batches: list[_Batch] = []
        self._autoreset = np.zeros(num_envs, dtype=bool)

    def reset(self, *, seed=None, options=None):
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [check_seed(seed) + i for i in range(n)]  # as gymnasium's SyncVectorEnv
        else:
            seeds = _seeds(seed)
            if len(seeds) != n:
                raise bad("seed", f"{len(seeds)} seeds", f"need one, or one per env ({n})")
        if self._rngs is None or seed is not None:
            self._rngs = [seeding.np_random(s)[0] for s in seeds]
        self._batches = []
        self._start(np.arange(n), options)
        self._autoreset[:] = False
        return self._observations(), self._infos()

    def step(self, actions):
        if not self._batches:
            raise bad("step", "before reset", "call reset() first")
        actions = checked_actions("actions", actions, self.action_space.shape)
        n = self.num_envs
        reward = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        stepping = [b for b in self._batches if b.running.any()]
        restarting = np.flatnonzero(self._autoreset)
        t0 = self.settings.config.transient_steps
        for batch in stepping:
            episode = batch.episode
            given = np.zeros((len(batch.envs), episode.n_voxels))
            given[batch.running] = actions[batch.envs[batch.running]]
            episode.step(given)
            ok = episode.status == STATUS_OK
            x = np.array(episode.com[:, 0])
            rows = batch.running.copy()
            envs = batch.envs[rows]
            reward[envs] = rewards(batch.x, x, ok, episode.k, t0)[rows]
            if episode.k == t0:
                batch.x_start = x
            batch.x = x
            terminated[envs] = ~ok[rows]
            truncated[envs] = ok[rows] & episode.done
            batch.running &= ok & (not episode.done)
        if restarting.size:
            self._start(restarting, None)
        self._batches = [b for b in self._batches if b.member.any()]
        self._autoreset = terminated | truncated
        return self._observations(), reward, terminated, truncated, self._infos()

    def _start(self, envs: np.ndarray, options) -> None:
        """New episodes for sub-environments ``envs``, as one batch."""
        drawn = [self.settings.draw(self._rngs[e], options) for e in envs]
        for e, (terrain, _) in zip(envs, drawn):
            self.terrains[e] = terrain
        for batch in self._batches:
            batch.member[np.isin(batch.envs, envs)] = False
        episode = Episode([Zero()] * len(envs), [t for t, _ in drawn], self.settings.config,
                          seeds=[s for _, s in drawn], bodies=[self.settings.body] * len(envs))
        x = np.array(episode.com[:, 0])
        self._batches.append(_Batch(episode, np.asarray(envs), np.ones(len(envs), dtype=bool),
                                    np.ones(len(envs), dtype=bool), x, x))

    def _observations(self) -> np.ndarray:
        obs = np.empty(self.observation_space.shape)
        r = self.settings.n_readings
        for batch in self._batches:
            rows = np.flatnonzero(batch.member)
            obs[batch.envs[rows]] = batch.episode.readings[rows, :r]
        return obs

    def _infos(self) -> dict:
        """Each sub-environment's control steps taken, time [s], x [m] and v_x so far [m/s]
        (where ``_velocity`` is False, before the transient ends or after a non-finite state,
        there is none: 0), as the single environment's ``info``."""
        n = self.num_envs
        step = np.zeros(n, dtype=np.int64)
        x = np.zeros(n)
        velocity = np.zeros(n)
        t0 = self.settings.config.transient_steps
        for batch in self._batches:
            rows = np.flatnonzero(batch.member)
            envs = batch.envs[rows]
            k = batch.episode.k
            ok = batch.episode.status == STATUS_OK
            step[envs] = k
            x[envs] = batch.x[rows]
            velocity[envs] = velocities(batch.x_start, batch.x, ok, k, t0)[rows]
        infos = {"step": step, "time": step / CONTROL_HZ, "x": x, "velocity": velocity}
        everyone = np.ones(n, dtype=bool)
        infos.update({f"_{key}": everyone for key in list(infos)})
        # Gymnasium's mask: velocity exists where the single env's info holds one; 0 elsewhere,
        # not NaN, so that equal steps give equal infos.
        infos["_velocity"] = np.isfinite(velocity)
        velocity[~infos["_velocity"]] = 0.0
        return infos

    def close_extras(self, **kwargs) -> None:
        self._batches = []


__all__ = ["LocomotionVectorEnv"]
