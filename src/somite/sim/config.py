"""Simulation settings, and the two presets of docs/decisions.md ("Presets") as data.

Every difference between the paper and the authors' code is one named option here; the presets
``paper`` (default) and ``original-code`` only choose values. Kernels receive the numbers packed
into one float64 vector (:func:`pack_params`), indexed by the ``P_*`` constants.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import NamedTuple

import numpy as np

from .. import checks
from ..errors import bad
from ..limits import MAX_DURATION

CONTROL_HZ = 60.0
VOXEL_SIDE = 3.0
CORNER_MASS = 0.36
"""[kg] of one corner block (the original's density quirk: 1.44 kg a voxel)."""
BLOCK_SIDE = 1.2
"""[m] side of a corner block: the original's MASS_SIDE_LENGTH_RATIO 0.4 of the voxel side."""
BLOCK_INERTIA = CORNER_MASS * 2 * BLOCK_SIDE**2 / 12
"""[kg m^2] of one block about its centre."""

LIDAR_PAPER = (-math.pi / 4, -math.pi / 8, 0.0, math.pi / 8, math.pi / 4)
LIDAR_ORIGINAL = (-math.pi / 5, -math.pi / 10, 0.0, math.pi / 10, math.pi / 5)

ACTIVATIONS = ("tanh", "sigmoid")
FRAMES = ("world", "voxel")
IN_VOXEL_FRAME = FRAMES.index("voxel")
"""``Params.lidar_frame`` and ``velocity_frame`` of a sensor that reads in its voxel's frame."""
NOISE_STREAMS = ("independent", "java-random-0")
VOXEL_ANGLES = ("vector-mean", "angle-mean")
MEAN_OF_ANGLES = VOXEL_ANGLES.index("angle-mean")
"""``Params.voxel_angle`` of the authors' voxel orientation (the mean of its corners' angles)."""


MAX_WINDOW = int(MAX_DURATION * CONTROL_HZ)
"""Control steps of a moving-average window: no longer than the longest episode."""


class Bound(NamedTuple):
    """A numeric setting's type and range: an integer, or a real number (finite), in
    [low, high] (``above``: in (low, high])."""

    integer: bool
    low: float
    high: float
    above: bool = False
    below_low: str = ""
    """The reason a value below ``low`` is refused, when it says more than the number."""

    def check(self, field: str, value):
        if self.integer:
            return checks.integer(field, value, int(self.low), int(self.high))
        number = checks.real(field, value, None, self.high)
        if self.below_low and number < self.low:
            raise bad(field, value, self.below_low)
        return checks.real(field, number, self.low, None, above=self.above)


BOUNDS: dict[str, Bound] = {
    # At least one control step; the longest episode of somite.limits.
    "duration": Bound(False, 1 / CONTROL_HZ, MAX_DURATION, below_low=(
        f"must be at least one control step ({1 / CONTROL_HZ:g} s)")),
    "transient": Bound(False, 0.0, MAX_DURATION),
    # [m] above the ground at the start (tests drop robots from ~2 km).
    "start_gap": Bound(False, 0.0, 1e4),
    # Each count multiplies the work of a step: the bounds keep one step under a second.
    "substeps": Bound(True, 1, 100),
    "velocity_iterations": Bound(True, 1, 1000),
    "position_iterations": Bound(True, 1, 1000),
    "spring_hz": Bound(False, 0.0, 1e3, above=True),
    "damping_ratio": Bound(False, 0.0, 1e3),
    "area_delta": Bound(False, 0.0, 0.99),  # 1 would shrink a voxel to nothing
    "gravity": Bound(False, 0.0, 1e3, above=True),
    "drag": Bound(False, 0.0, 1e3),
    "friction": Bound(False, 0.0, 1e3),
    "block_friction": Bound(False, 0.0, 1e3),
    "restitution": Bound(False, 0.0, 1.0),
    "noise_sigma": Bound(False, 0.0, 1e3),
    "lidar_range": Bound(False, 0.0, 1e4, above=True),
    "touch_window": Bound(True, 1, MAX_WINDOW),
    "velocity_window": Bound(True, 1, MAX_WINDOW),
    "velocity_max": Bound(False, 0.0, 1e3, above=True),
}
"""Every numeric field of :class:`SimConfig` (but ``lidar_angles``: 5 angles in [-pi, pi]),
with its type and range: a value outside is a one-line error naming the field, so no count
can make a step run for hours and no length can overflow. Far beyond the paper's and the
original code's values (the defaults below) and any calibration's."""

CHOICES: dict[str, tuple[str, ...]] = {
    "lidar_frame": FRAMES,
    "velocity_frame": FRAMES,
    "hidden_activation": ACTIVATIONS,
    "noise_stream": NOISE_STREAMS,
    "voxel_angle": VOXEL_ANGLES,
}
"""Every text field of :class:`SimConfig` and the values it takes."""


@dataclass(frozen=True)
class SimConfig:
    """Everything that decides one episode besides the body, terrain and controller.

    Lengths in m, times in s, masses in kg. ``*_window`` are moving-average windows in control
    steps (1 = the current reading only).

    ``noise_stream``: ``independent`` (somite) draws every reading's noise afresh from the
    robot's seed, step and reading; ``java-random-0`` (the authors' code) gives every sensor of
    every voxel the same ``java.util.Random(0)`` Gaussian sequence, restarted each episode, so
    the seed is ignored (docs/original-system.md section 2.1).

    The physics (:mod:`somite.sim.physics`) takes ``substeps`` steps of 1 / (60 substeps) s per
    control step (the original: 1), each with ``velocity_iterations`` velocity passes and at
    most ``position_iterations`` position passes (dyn4j's 10 and 10); ``spring_hz`` and
    ``damping_ratio`` are the soft springs' (8 Hz, 0.3), ``friction`` is a block's on the ground
    (the original's mix, sqrt(10 x 0.2)), ``block_friction`` a block's on another block (10);
    all the original's values (docs/original-system.md section 1), none fitted.

    ``voxel_angle``, the voxel's orientation for voxel-frame sensors: ``vector-mean`` (somite)
    is the direction of the sum of the bottom and top side vectors; ``angle-mean`` (the authors'
    code) is the plain mean of the two sides' atan2 angles, which is off by pi when the two
    straddle +-pi, as for an upside-down voxel (docs/original-system.md section 1.2).
    """

    duration: float = 30.0
    transient: float = 5.0
    start_gap: float = 1.0
    substeps: int = 1
    velocity_iterations: int = 10
    position_iterations: int = 10
    spring_hz: float = 8.0
    damping_ratio: float = 0.3
    area_delta: float = 0.225
    gravity: float = 9.8
    drag: float = 0.1
    friction: float = math.sqrt(10.0 * 0.2)
    block_friction: float = 10.0
    restitution: float = 0.1
    noise_sigma: float = 0.01
    lidar_range: float = 10.0
    lidar_angles: tuple[float, ...] = LIDAR_PAPER
    lidar_frame: str = "world"
    touch_window: int = 1
    velocity_window: int = 1
    velocity_frame: str = "world"
    velocity_max: float = 8.0
    hidden_activation: str = "tanh"
    noise_stream: str = "independent"
    voxel_angle: str = "vector-mean"

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name in BOUNDS:
                object.__setattr__(self, f.name, BOUNDS[f.name].check(f.name, value))
            elif f.name in CHOICES:
                checks.text(f.name, value, CHOICES[f.name])
        angles = checks.items("lidar_angles", self.lidar_angles, 100)
        if len(angles) != 5:
            raise bad("lidar_angles", self.lidar_angles, "a lidar has exactly 5 rays")
        object.__setattr__(self, "lidar_angles", tuple(
            checks.real(f"lidar_angles[{i}]", a, -math.pi, math.pi)
            for i, a in enumerate(angles)))

    @property
    def n_steps(self) -> int:
        """Control steps of one episode."""
        return int(round(self.duration * CONTROL_HZ))

    @property
    def transient_steps(self) -> int:
        """The control step from which v_x is measured (0 when the episode is too short:
        :attr:`measures_whole_episode`)."""
        step = int(round(self.transient * CONTROL_HZ))
        return step if step < self.n_steps else 0

    @property
    def measures_whole_episode(self) -> bool:
        """Whether a duration no longer than the transient dropped the transient, so that v_x
        is measured over the whole episode [0, duration], start-up included, instead of over
        [transient, duration]. Commands say so (:func:`whole_episode_warning`): a fitness
        over another interval is not comparable with the paper's. Building such a config from
        Python does not warn: short configs are built on purpose everywhere (tests, a campaign's
        workers, ``dataclasses.replace``), where a warning each time would be noise; read this
        property, or :attr:`measured_interval`, to know."""
        return self.transient > 0 and int(round(self.transient * CONTROL_HZ)) >= self.n_steps

    @property
    def measured_interval(self) -> tuple[float, float]:
        """[s] the interval v_x is measured over: (transient, duration), or (0, duration)."""
        return self.transient_steps / CONTROL_HZ, self.n_steps / CONTROL_HZ

    def with_options(self, **options) -> SimConfig:
        known = {f.name for f in fields(self)}
        for name in options:
            if name not in known:  # a keyword is always a string
                raise bad("option", name, "not a simulation option")
        return replace(self, **options)

    def to_dict(self) -> dict:
        data = asdict(self)
        data["lidar_angles"] = list(self.lidar_angles)
        return data


def whole_episode_warning(config: SimConfig) -> str | None:
    """The one-line warning a command prints when ``config`` measures v_x over the whole
    episode (:attr:`SimConfig.measures_whole_episode`); None when it does not."""
    if not config.measures_whole_episode:
        return None
    return (f"duration={config.duration:g} s is not longer than transient="
            f"{config.transient:g} s: v_x is measured over the whole episode "
            f"[0 s, {config.duration:g} s], start-up included, not over [transient, duration]")


PRESETS: dict[str, dict] = {
    "paper": {},
    "original-code": {
        "hidden_activation": "sigmoid",
        "lidar_angles": LIDAR_ORIGINAL,
        "lidar_frame": "voxel",
        "touch_window": 16,
        "velocity_window": 31,
        "velocity_frame": "voxel",
        "noise_stream": "java-random-0",
        "voxel_angle": "angle-mean",
    },
}
"""The simulation half of each preset (docs/decisions.md, "Presets")."""


def preset(name: str, **options) -> SimConfig:
    """The :class:`SimConfig` of preset ``name``, with ``options`` on top."""
    checks.text("preset", name, list(PRESETS))
    return SimConfig().with_options(**{**PRESETS[name], **options})


class Params(NamedTuple):
    """What the kernels read of a :class:`SimConfig`: derived numbers, typed, SI units."""

    dt: float  # [s] one physics step
    substeps: int  # physics steps per control step
    velocity_iterations: int  # passes of the velocity solver per step
    position_iterations: int  # most passes of the position solver per step
    spring_hz: float  # [Hz] the springs' frequency
    damping_ratio: float  # the springs' damping ratio
    gravity: float  # [m/s^2]
    drag: float  # [1/s]
    friction: float  # Coulomb coefficient, block on ground
    block_friction: float  # Coulomb coefficient, block on block
    restitution: float  # of impacts faster than physics.RESTITUTION_SPEED
    contract: float  # rest-length scale at actuation +1
    expand: float  # rest-length scale at actuation -1
    noise: float  # sensor noise sigma
    lidar_range: float  # [m]
    lidar_frame: int  # FRAMES index
    touch_window: int  # control steps
    velocity_window: int  # control steps
    velocity_frame: int  # FRAMES index
    velocity_max: float  # [m/s]
    hidden_sigmoid: bool  # hidden neurons: sigmoid (else tanh)
    transient_steps: int  # control steps before v_x is measured
    voxel_angle: int  # VOXEL_ANGLES index
    lidar_angles: np.ndarray  # (5,) ray angles [rad] (an array: prange kernels take no
    # tuples inside tuples)


def pack_params(config: SimConfig) -> Params:
    """The kernels' view of ``config``."""
    return Params(
        dt=1.0 / CONTROL_HZ / config.substeps,
        substeps=config.substeps,
        velocity_iterations=config.velocity_iterations,
        position_iterations=config.position_iterations,
        spring_hz=float(config.spring_hz),
        damping_ratio=float(config.damping_ratio),
        gravity=float(config.gravity),
        drag=float(config.drag),
        friction=float(config.friction),
        block_friction=float(config.block_friction),
        restitution=float(config.restitution),
        contract=math.sqrt(1 - config.area_delta),
        expand=math.sqrt(1 + config.area_delta),
        noise=float(config.noise_sigma),
        lidar_range=float(config.lidar_range),
        lidar_frame=FRAMES.index(config.lidar_frame),
        touch_window=config.touch_window,
        velocity_window=config.velocity_window,
        velocity_frame=FRAMES.index(config.velocity_frame),
        velocity_max=float(config.velocity_max),
        hidden_sigmoid=config.hidden_activation == "sigmoid",
        transient_steps=config.transient_steps,
        voxel_angle=VOXEL_ANGLES.index(config.voxel_angle),
        lidar_angles=np.array(config.lidar_angles, dtype=np.float64),
    )
