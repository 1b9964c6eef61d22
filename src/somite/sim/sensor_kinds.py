"""Sensor kinds, defined once: the table that the body, the batch arrays, the sensing kernel and
the drawings read (docs/original-system.md section 2).

A voxel's sensors give readings of one kind each: a kind's row in :data:`SENSORS` says how many
values one sensor gives, what colour its sector is drawn in, how many of the authors'
``java.util.Random(0)`` Gaussians it spends per step and which :class:`~somite.sim.config.SimConfig`
fields it reads. A kind's code is its position in the table, and the sensing kernel
(:func:`somite.sim.sensors.sense`) has one branch per code; each scalar reading has a reading
code, derived from the table (:func:`reading_code`). The table's order is also the order
in which a voxel lists its sensors when built from a preset or a mapping.

The kernels of :mod:`somite.sim.sensors` compile these codes and strides in; the compiled
kernels are cached under a hash of every kernel source (:mod:`somite._jit`), so an edit of
either file is seen on the next call.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SensorKind(NamedTuple):
    """One kind of sensor (a row of :data:`SENSORS`)."""

    name: str
    width: int
    """Scalar readings one sensor gives (its components 0 .. width - 1)."""
    colour: tuple[int, int, int]
    """RGB of its sector in drawn frames (:mod:`somite.viz.frame`)."""
    noise_stride: int
    """Gaussians its ``java-random-0`` stream spends per control step: component c at step k
    (from 0) gets Gaussian ``noise_stride * k + c`` of :func:`~somite.sim.sensors.noise_table`."""
    settings: tuple[str, ...]
    """The :class:`~somite.sim.config.SimConfig` fields that only this kind reads (besides the
    noise and ``voxel_angle``, which voxel-frame sensors share)."""
    components: tuple[str, ...] = ()
    """Names of its components, as observation names end (``velocity.x``); empty: numbered
    0 .. width - 1 (``lidar.2``), a kind of width 1 none."""


SENSORS = (
    SensorKind("area", 1, (255, 255, 255), 1, ()),
    SensorKind("touch", 1, (20, 20, 20), 1, ("touch_window",)),
    SensorKind("velocity", 2, (40, 100, 210), 2,
               ("velocity_window", "velocity_frame", "velocity_max"), ("x", "y")),
    SensorKind("lidar", 5, (220, 30, 30), 5, ("lidar_range", "lidar_angles", "lidar_frame")),
)
"""Every sensor kind; a kind's position here is its code."""

SENSOR_CODE = {kind.name: code for code, kind in enumerate(SENSORS)}
"""Kind name -> code."""

AREA, TOUCH, VELOCITY, LIDAR = (SENSOR_CODE[name] for name in ("area", "touch", "velocity",
                                                               "lidar"))

NOISE_STRIDE = np.array([kind.noise_stride for kind in SENSORS], dtype=np.int64)
"""(kinds,) :attr:`SensorKind.noise_stride` by kind code, as the sensing kernel reads it."""

READING_KIND = np.array([code for code, kind in enumerate(SENSORS) for _ in range(kind.width)],
                        dtype=np.int64)
"""Reading code -> kind code. A reading code numbers the (kind, component) pairs in the table's
order (area 0, touch 1, velocity 2 and 3, lidar 4 to 8): what a batch stores per reading
(``System.reading_code``, :func:`reading_code`)."""

READING_COMPONENT = np.array([c for kind in SENSORS for c in range(kind.width)], dtype=np.int64)
"""Reading code -> component (0 .. width - 1) of its kind."""


def component_name(kind: str, component: int) -> str:
    """How observation names end for component ``component`` of a sensor of kind ``kind``:
    ``velocity.x``, ``lidar.2``, ``touch``."""
    row = SENSORS[SENSOR_CODE[kind]]
    if row.components:
        return f"{kind}.{row.components[component]}"
    return kind if row.width == 1 else f"{kind}.{component}"


def reading_code(kind: str, component: int) -> int:
    """The reading code of component ``component`` of a sensor of kind ``kind``."""
    code = SENSOR_CODE[kind]
    return sum(k.width for k in SENSORS[:code]) + component


__all__ = ["AREA", "LIDAR", "NOISE_STRIDE", "READING_COMPONENT", "READING_KIND", "SENSORS",
           "SENSOR_CODE", "TOUCH", "VELOCITY", "SensorKind", "component_name", "reading_code"]
