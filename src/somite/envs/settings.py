"""What a somite Gymnasium environment is made of, checked, and the arithmetic its steps share.

The single environment (:mod:`somite.envs.locomotion`) and the vector one
(:mod:`somite.envs.vector`) take the same keyword arguments (:func:`settings`), draw an
episode's terrain and noise seed the same way (:meth:`EnvSettings.draw`) and compute rewards
with the same function (:func:`rewards`), so that sub-environment i of a vector environment
gives the numbers of a single environment, bit for bit. Nothing here imports gymnasium.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from numbers import Integral, Real

import numpy as np

from ..errors import bad, bad_type
from ..limits import MAX_STEPPED, MAX_VALIDATION, at_most
from ..sim.body import Body, Shape
from ..sim.config import CONTROL_HZ, SimConfig
from ..sim.config import preset as sim_preset
from ..sim.sensor_kinds import component_name
from ..sim.sensors import noise_table
from ..sim.terrain import Terrain, parse_terrain
from ..tasks.distributions import TerrainDistribution, parse_distribution
from ..tasks.stepper import real_array
from ..tasks.validation import ValidationSet, is_fresh_terrain

GAUSSIAN_BOUND = math.sqrt(-2.0 * math.log(2.0**-62)) + 1e-9
"""Largest |z| that the independent noise stream can draw: Marsaglia's polar method on 32-bit
uniforms (:func:`somite.sim.sensors.gaussian_pair`) has s >= 2**-62 and |z| <= sqrt(-2 ln s),
about 9.27 standard deviations."""

NOISE_SEEDS = 2**63
"""A sensor-noise seed is drawn uniform in [0, NOISE_SEEDS)."""


@dataclass(frozen=True)
class EnvSettings:
    """An environment's body, terrain distribution and simulation settings, checked."""

    body: Body
    terrains: TerrainDistribution
    config: SimConfig

    @property
    def n_readings(self) -> int:
        return self.body.n_readings

    @property
    def n_voxels(self) -> int:
        return self.body.shape.n_voxels

    @cached_property
    def observation_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) of every reading: the sensors give [0, 1] (soft-normalised area and
        velocity, touch, lidar distance over range), plus the noise, unclipped, whose largest
        draw is known (:data:`GAUSSIAN_BOUND`; the authors' table's own largest)."""
        config = self.config
        z = 0.0
        if config.noise_sigma > 0:
            table = noise_table(config)
            z = float(np.abs(table).max()) if len(table) else GAUSSIAN_BOUND
        # A hair over sigma * z: the sum is rounded once more than the bound.
        spread = config.noise_sigma * z * (1 + 1e-9)
        low = np.full(self.n_readings, -spread)
        high = np.full(self.n_readings, 1.0 + spread)
        return low, high

    @cached_property
    def observation_names(self) -> tuple[str, ...]:
        """One name a reading, in the observation's order: voxel by voxel (the shape's order,
        bottom row first, left to right), sensor by sensor as the voxel lists them, e.g.
        ``v3(1,0).velocity.x``, ``v3(1,0).lidar.2``."""
        names = []
        for reading in self.body.readings:
            x, y = self.body.shape.voxels[reading.voxel]
            ending = component_name(reading.kind, reading.component)
            names.append(f"v{reading.voxel}({x},{y}).{ending}")
        return tuple(names)

    @cached_property
    def action_names(self) -> tuple[str, ...]:
        """One name a voxel, in the action's order: ``v0(0,0)``, ... (+1 contracts)."""
        return tuple(f"v{v}({x},{y})" for v, (x, y) in enumerate(self.body.shape.voxels))

    def draw(self, rng: np.random.Generator, options: dict | None = None) -> tuple[Terrain, int]:
        """An episode's terrain (a ``-rnd`` distribution's draw, else its terrain) and sensor
        noise seed, from ``rng``; ``options`` may fix either (``terrain``: a terrain name,
        ``noise_seed``: an int, as ``somite simulate --seed`` takes it)."""
        if options is not None and not isinstance(options, Mapping):
            raise bad_type("options", options, "a dict (terrain=, noise_seed=) or None")
        options = dict(options or {})
        unknown = set(options) - {"terrain", "noise_seed"}
        if unknown:
            raise bad("options", sorted(unknown)[0], "known options: terrain, noise_seed")
        terrain = self.terrains.sample(rng, 1)[0]
        seed = int(rng.integers(0, NOISE_SEEDS))
        if "terrain" in options:
            value = options["terrain"]
            if not isinstance(value, (str, Terrain)):
                raise bad_type("terrain", value, "a terrain name or a Terrain")
            terrain = value if isinstance(value, Terrain) else parse_terrain(value)
            check_training_terrain(terrain.name)
        if "noise_seed" in options:
            value = options["noise_seed"]
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
                    0 <= value < 2**64):
                raise bad("noise_seed", value, "must be an integer in [0, 2**64)")
            seed = int(value)
        return terrain, seed


def settings(shape="worm", terrain="flat", duration=30.0, preset="paper",
             sensors="paper") -> EnvSettings:
    """The environments' keyword arguments, checked (a one-line error names the first bad one).

    ``shape``: ``worm``, ``biped``, ``WxH`` or rows of 1/0 (``1111/1111/1001``), or a
    :class:`~somite.sim.body.Shape`; ``terrain``: a terrain (``flat``, ``hilly-1-10-3``) or a
    distribution (``hilly-1-10-rnd``: a new terrain each reset); ``duration`` [s];
    ``preset``: ``paper`` or ``original-code``; ``sensors``: ``paper``, ``all`` or ``area``
    (which sensors each voxel has)."""
    if isinstance(shape, str):
        shape = Shape.parse(shape)
    elif not isinstance(shape, Shape):
        raise bad("shape", shape, "expected worm, biped, WxH or rows of 1/0 like 1111/1111/1001")
    if not isinstance(sensors, str):
        raise bad("sensors", sensors, "expected a sensor preset: paper, all or area")
    body = Body.build(shape, sensors)
    if body.n_readings == 0:
        raise bad("sensors", sensors, "the body has no sensor: an observation needs one")
    if not isinstance(terrain, str):
        raise bad("terrain", terrain, "expected a terrain or distribution name, e.g. "
                  "flat or hilly-1-10-rnd")
    distribution = parse_distribution(terrain)
    if not distribution.is_random:
        check_training_terrain(distribution.name)
    if isinstance(duration, bool) or not isinstance(duration, Real):
        raise bad("duration", duration, "expected a number of seconds")
    if not isinstance(preset, str):
        raise bad("preset", preset, "use paper or original-code")
    config = sim_preset(preset, duration=float(duration))
    return EnvSettings(body, distribution, config)


def check_training_terrain(name: str) -> None:
    """Refuse a terrain somite keeps out of training, as ``somite evolve`` does: a validation
    terrain (hilly-1-10-10000 on, of any count up to :data:`~somite.limits.MAX_VALIDATION`)
    or a fresh one (hilly-1-10-20000 on), on which runs and the report measure robots that
    never met them."""
    if name in _HELD_OUT or is_fresh_terrain(name):
        raise bad("terrain", name, "a validation or fresh terrain cannot be trained on (somite "
                  "measures robots there that never met it); use another seed, e.g. "
                  "hilly-1-10-3, or hilly-1-10-rnd")


_HELD_OUT = frozenset(ValidationSet.of(MAX_VALIDATION).names)


def check_seed(value, field: str = "seed") -> int | None:
    """A reset's seed: None or a non-negative integer (NumPy's too), as an int; checked here
    so that a bad one is a somite error naming it, as every other argument is."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise bad_type(field, value, "None or a non-negative integer")
    if value < 0:
        raise bad(field, value, "must be None or a non-negative integer")
    return int(value)


def check_num_envs(value) -> int:
    """A vector environment's ``num_envs``: a positive integer (NumPy's too), at most
    :data:`~somite.limits.MAX_STEPPED`, checked before anything is allocated."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise bad_type("num_envs", value, "a positive integer")
    value = int(value)
    if value < 1:
        raise bad("num_envs", value, "must be a positive integer")
    at_most("num_envs", value, MAX_STEPPED)
    return value


def checked_actions(field: str, value, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as float64 of ``shape``, checked before it is converted: real numbers only
    (a string, a bool, a complex or an object would convert to a float silently), every one
    in [-1, 1] (NaN refused)."""
    array = real_array(field, value).copy()  # the caller keeps its own array
    if array.shape != shape:
        raise bad(field, f"shape {array.shape}", f"must have shape {shape}")
    inside = np.abs(array) <= 1.0  # False for NaN
    if not inside.all():
        raise bad(field, float(array.flat[np.argmin(inside)]), "every value must be in [-1, 1]")
    return array


def rewards(x_before: np.ndarray, x_after: np.ndarray, ok: np.ndarray, k: int,
            transient_steps: int) -> np.ndarray:
    """The rewards of control step ``k``: x-progress of the centre of mass over the step in m/s
    (``x_after - x_before`` [m] times the control rate) once past the transient
    (``k > transient_steps``), else 0; 0 for a robot that went non-finite (not ``ok``).
    Summed over the counted steps and divided by their number: the episode's v_x (paper eq. 2),
    as :func:`somite.simulate` gives it, to rounding."""
    progress = np.zeros(len(x_after))
    if k > transient_steps:
        np.subtract(x_after, x_before, out=progress, where=ok)
        progress *= CONTROL_HZ
    return progress


def velocities(x_start: np.ndarray, x_now: np.ndarray, ok: np.ndarray, k: int,
               transient_steps: int) -> np.ndarray:
    """v_x [m/s] so far: over [transient, step k], the way
    :func:`~somite.tasks.locomotion.outcomes` computes it over [transient, duration] (so at the
    end it is the episode's v_x, bit for bit); NaN before the transient ends or for a robot that
    went non-finite."""
    velocity = np.full(len(x_now), np.nan)
    if k > transient_steps:
        span = (k - transient_steps) / CONTROL_HZ
        np.subtract(x_now, x_start, out=velocity, where=ok)
        np.divide(velocity, span, out=velocity, where=ok)
    return velocity


__all__ = ["EnvSettings", "check_num_envs", "check_seed", "check_training_terrain",
           "checked_actions", "rewards", "settings", "velocities"]
