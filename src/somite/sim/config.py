"""Simulation settings, and the two presets of decisions.md as data.

Every difference between the paper and the authors' code is one named option here; the presets
``paper`` (default) and ``original-code`` only choose values. Kernels receive the numbers packed
into one float64 vector (:func:`pack_params`), indexed by the ``P_*`` constants.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from ..errors import bad

CONTROL_HZ = 60.0
VOXEL_SIDE = 3.0
CORNER_MASS = 0.36

LIDAR_PAPER = (-math.pi / 4, -math.pi / 8, 0.0, math.pi / 8, math.pi / 4)
LIDAR_ORIGINAL = (-math.pi / 5, -math.pi / 10, 0.0, math.pi / 10, math.pi / 5)

ACTIVATIONS = ("tanh", "sigmoid")
FRAMES = ("world", "voxel")
NOISE_STREAMS = ("independent", "java-random-0")
VOXEL_ANGLES = ("vector-mean", "angle-mean")


@dataclass(frozen=True)
class SimConfig:
    """Everything that decides one episode besides the body, terrain and controller.

    Lengths in m, times in s, masses in kg. ``*_window`` are moving-average windows in control
    steps (1 = the current reading only).

    ``noise_stream``: ``independent`` (somite) draws every reading's noise afresh from the
    robot's seed, step and reading; ``java-random-0`` (the authors' code) gives every sensor of
    every voxel the same ``java.util.Random(0)`` Gaussian sequence, restarted each episode, so
    the seed is ignored (original-system.md section 2.1).

    ``voxel_angle``, the voxel's orientation for voxel-frame sensors: ``vector-mean`` (somite)
    is the direction of the sum of the bottom and top side vectors; ``angle-mean`` (the authors'
    code) is the plain mean of the two sides' atan2 angles, which is off by pi when the two
    straddle +-pi, as for an upside-down voxel (original-system.md section 1.2).
    """

    duration: float = 30.0
    transient: float = 5.0
    start_gap: float = 1.0
    substeps: int = 8
    spring_hz: float = 8.0
    damping_ratio: float = 0.3
    diagonal_stiffness: float = 1.0
    area_delta: float = 0.225
    min_side_ratio: float = 0.8
    min_diagonal_ratio: float = 0.5
    min_area_ratio: float = 0.3
    gravity: float = 9.8
    drag: float = 0.1
    friction: float = 1.4
    max_peak_depth: float = 0.2
    contact_radius: float = 0.0
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
            if isinstance(value, float) and not math.isfinite(value):
                raise bad(f.name, value, "must be a finite number")
        if not self.duration > 0:
            raise bad("duration", self.duration, "must be positive")
        if self.transient < 0:
            raise bad("transient", self.transient, "must be zero or positive")
        _positive_int(self, "substeps", "touch_window", "velocity_window")
        for name in ("spring_hz", "lidar_range", "velocity_max", "gravity", "diagonal_stiffness"):
            if not getattr(self, name) > 0:
                raise bad(name, getattr(self, name), "must be positive")
        non_negative = (
            "start_gap", "damping_ratio", "drag", "friction", "noise_sigma", "max_peak_depth",
            "contact_radius",
        )
        for name in non_negative:
            if getattr(self, name) < 0:
                raise bad(name, getattr(self, name), "must be zero or positive")
        if not 0 <= self.area_delta < 1:
            raise bad("area_delta", self.area_delta, "must be in [0, 1)")
        for name in ("min_side_ratio", "min_diagonal_ratio", "min_area_ratio"):
            if not 0 < getattr(self, name) < 1:
                raise bad(name, getattr(self, name), "must be in (0, 1)")
        if len(self.lidar_angles) != 5:
            raise bad("lidar_angles", self.lidar_angles, "a lidar has exactly 5 rays")
        for name, allowed in (
            ("lidar_frame", FRAMES),
            ("velocity_frame", FRAMES),
            ("hidden_activation", ACTIVATIONS),
            ("noise_stream", NOISE_STREAMS),
            ("voxel_angle", VOXEL_ANGLES),
        ):
            if getattr(self, name) not in allowed:
                raise bad(name, getattr(self, name), f"use one of {allowed}")

    @property
    def n_steps(self) -> int:
        """Control steps of one episode."""
        return int(round(self.duration * CONTROL_HZ))

    @property
    def transient_steps(self) -> int:
        """The control step from which v_x is measured (0 when the episode is too short)."""
        step = int(round(self.transient * CONTROL_HZ))
        return step if step < self.n_steps else 0

    def with_options(self, **options) -> SimConfig:
        known = {f.name for f in fields(self)}
        for name in options:
            if name not in known:
                raise bad("option", name, "not a simulation option")
        return replace(self, **options)

    def to_dict(self) -> dict:
        data = asdict(self)
        data["lidar_angles"] = list(self.lidar_angles)
        return data


def _positive_int(config: SimConfig, *names: str) -> None:
    for name in names:
        value = getattr(config, name)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise bad(name, value, "must be a positive integer")


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
"""The simulation half of each preset (decisions.md, "Two presets, one code path")."""


def preset(name: str, **options) -> SimConfig:
    """The :class:`SimConfig` of preset ``name``, with ``options`` on top."""
    if name not in PRESETS:
        raise bad("preset", name, f"use one of {list(PRESETS)}")
    return SimConfig().with_options(**{**PRESETS[name], **options})


# Layout of the packed parameter vector read by the kernels.
(
    P_DT,
    P_SUBSTEPS,
    P_STIFFNESS,
    P_DAMPING,
    P_GRAVITY,
    P_DRAG,
    P_FRICTION,
    P_CONTRACT,
    P_EXPAND,
    P_DIAGONAL,
    P_MIN_SIDE,
    P_MIN_DIAGONAL,
    P_MIN_AREA,
    P_PEAK_DEPTH,
    P_RADIUS,
    P_NOISE,
    P_LIDAR_RANGE,
    P_LIDAR_FRAME,
    P_TOUCH_WINDOW,
    P_VELOCITY_WINDOW,
    P_VELOCITY_FRAME,
    P_VELOCITY_MAX,
    P_HIDDEN_SIGMOID,
    P_TRANSIENT_STEPS,
    P_VOXEL_ANGLE,
    P_LIDAR0,
) = range(26)
N_PARAMS = P_LIDAR0 + 5


def pack_params(config: SimConfig) -> np.ndarray:
    """The kernel's view of ``config``: one float64 vector indexed by ``P_*``."""
    omega = 2 * math.pi * config.spring_hz
    reduced_mass = CORNER_MASS / 2  # two corner masses joined by one spring
    params = np.zeros(N_PARAMS, dtype=np.float64)
    params[P_DT] = 1.0 / CONTROL_HZ / config.substeps
    params[P_SUBSTEPS] = config.substeps
    params[P_STIFFNESS] = reduced_mass * omega**2
    params[P_DAMPING] = 2 * reduced_mass * config.damping_ratio * omega
    params[P_GRAVITY] = config.gravity
    params[P_DRAG] = config.drag
    params[P_FRICTION] = config.friction
    params[P_CONTRACT] = math.sqrt(1 - config.area_delta)
    params[P_EXPAND] = math.sqrt(1 + config.area_delta)
    params[P_DIAGONAL] = config.diagonal_stiffness
    params[P_MIN_SIDE] = config.min_side_ratio
    params[P_MIN_DIAGONAL] = config.min_diagonal_ratio
    params[P_MIN_AREA] = config.min_area_ratio
    params[P_PEAK_DEPTH] = config.max_peak_depth
    params[P_RADIUS] = config.contact_radius
    params[P_NOISE] = config.noise_sigma
    params[P_LIDAR_RANGE] = config.lidar_range
    params[P_LIDAR_FRAME] = FRAMES.index(config.lidar_frame)
    params[P_TOUCH_WINDOW] = config.touch_window
    params[P_VELOCITY_WINDOW] = config.velocity_window
    params[P_VELOCITY_FRAME] = FRAMES.index(config.velocity_frame)
    params[P_VELOCITY_MAX] = config.velocity_max
    params[P_HIDDEN_SIGMOID] = ACTIVATIONS.index(config.hidden_activation)
    params[P_TRANSIENT_STEPS] = config.transient_steps
    params[P_VOXEL_ANGLE] = VOXEL_ANGLES.index(config.voxel_angle)
    params[P_LIDAR0 : P_LIDAR0 + 5] = config.lidar_angles
    return params


