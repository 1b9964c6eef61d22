"""Controller specifications: what the episode kernel runs for one robot.

``Zero``, ``Sine`` and ``Table`` are open-loop; ``GraphArrays`` is a graph controller already
flattened to arrays (the genome of :mod:`somite.brain.genome` compiles to it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import bad


@dataclass(frozen=True)
class Zero:
    """Every voxel at rest (actuation 0)."""


@dataclass(frozen=True)
class Sine:
    """a_v(t) = amp * sin(2 pi freq t + phase * x_v); phase < 0 travels towards +x.

    Actuation i, in force over [i, i + 1] / 60 s, is a_v(i / 60) for i >= 1 and 0 for i = 0:
    every controller starts at rest (docs/architecture.md, "Step 0")."""

    freq: float = 1.0
    amp: float = 1.0
    phase: float = -1.0

    def __post_init__(self) -> None:
        for name in ("freq", "amp", "phase"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise bad(f"controller.{name}", value, "must be a finite number")
        if self.freq < 0:
            raise bad("controller.freq", self.freq, "must be zero or positive")


@dataclass(frozen=True, eq=False)
class Table:
    """Actuation rows (L, V) replayed periodically: actuation i, in force over
    [i, i + 1] / 60 s, is row i mod L, except actuation 0, which is 0 as for every controller
    (the robot starts at rest: docs/architecture.md, "Step 0"). Row 0 is first used at i = L.

    So the actions that a ``somite/Locomotion-v0`` episode took (the i-th ``step`` call's
    action is actuation i; the first is not put in force) replay as ``Table(actions)`` through
    :func:`somite.simulate`, bit for bit (tests/test_gym.py)."""

    rows: np.ndarray

    def __post_init__(self) -> None:
        rows = np.asarray(self.rows, dtype=np.float64)
        if rows.ndim != 2 or rows.shape[0] < 1:
            raise bad("controller.rows", rows.shape, "expected a non-empty (steps, voxels) table")
        if not np.all(np.isfinite(rows)):
            raise bad("controller.rows", "non-finite", "actuation must be finite")
        object.__setattr__(self, "rows", rows)


@dataclass(frozen=True, eq=False)
class GraphArrays:
    """A graph controller as flat arrays: node kinds and references, edges by node index."""

    node_kind: np.ndarray  # (N,) KIND_DTYPE codes SENSOR / HIDDEN / ACTUATOR
    node_ref: np.ndarray  # (N,) int32 reading (sensor) or voxel (actuator), -1 otherwise
    src: np.ndarray  # (E,) int32
    dst: np.ndarray  # (E,) int32
    weight: np.ndarray  # (E,)
    bias: np.ndarray  # (E,)
    body: object = None
    """The :class:`~somite.sim.body.Body` it was compiled for (None: not known), so that a
    batch refuses it on another body instead of reading past that body's readings."""

    @property
    def n_nodes(self) -> int:
        return len(self.node_kind)

    @property
    def n_edges(self) -> int:
        return len(self.src)
