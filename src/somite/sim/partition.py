"""Partitions of a body into modules: every voxel gets a module label, and the partition file.

A module is a 4-connected set of voxels (docs/decisions.md, "Partitions"). The paper's manual
partitions (paper Figure 6, docs/original-system.md section 6.1) depend on x only: the worm's back
half x <= 2 and front half x >= 3; the biped's two legs (whole columns x = 0 and x = 3) and its
torso x in {1, 2}.

A partition describes a body, so it lives beside :class:`~somite.sim.body.Shape`; the controller
operators, module cutting and drawing all read it from here. File format (JSON, written by
``somite discover`` and read by every command that takes a partition)::

    {"format": "somite-partition", "version": 1, "shape": "111111/111111",
     "grid": "AAABBB/AAABBB", "modules": {"A": [[0, 0], ...], "B": [...]}, ...}

``grid`` (rows of one-character labels from the top, '.' for empty cells) is what is read back;
``modules`` lists each module's voxels for readers; other keys are the writer's notes.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from .._io import read_json, write_atomic
from ..errors import bad
from ..formats import PARTITION
from .body import PRESET_SHAPES, Shape, is_connected


def _worm_halves(x: int, y: int) -> str:
    return "back" if x <= 2 else "front"


def _biped_legs(x: int, y: int) -> str:
    return {0: "left-leg", 3: "right-leg"}.get(x, "torso")


PARTITION_PRESETS: dict[str, tuple[str, Callable[[int, int], str]]] = {
    "worm-halves": (PRESET_SHAPES["worm"], _worm_halves),
    "biped-legs": (PRESET_SHAPES["biped"], _biped_legs),
}
"""Preset name -> (the shape it is for, as a grid string; voxel (x, y) -> module label)."""

PAPER_PRESET = {grid: name for name, (grid, _) in PARTITION_PRESETS.items()}
"""Shape grid string -> the paper's partition preset for that shape."""


@dataclass(frozen=True)
class Partition:
    """A module label for every voxel of a shape: ``labels[i]`` is the module of
    ``shape.voxels[i]``; labels are non-empty strings, and each module is 4-connected."""

    shape: Shape
    labels: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "labels", tuple(self.labels))
        if len(self.labels) != self.shape.n_voxels:
            raise bad(
                "partition.labels", len(self.labels),
                f"need one label per voxel ({self.shape.n_voxels} voxels)",
            )
        for label in self.labels:
            if not isinstance(label, str) or not label or label == ".":
                raise bad("partition.labels", label, "module labels are non-empty strings, not '.'")
        for label in self.modules:
            if not is_connected(set(self.voxels_of(label))):
                raise bad("partition", label, "module is not 4-connected")

    @classmethod
    def preset(cls, name: str, shape: Shape | str) -> Partition:
        """A named partition: ``worm-halves``, ``biped-legs``, or ``paper`` (the shape's own)."""
        shape = Shape.parse(shape) if isinstance(shape, str) else shape
        grid = shape.grid_string()
        if name == "paper":
            if grid not in PAPER_PRESET:
                raise bad("partition", name, f"the paper has no partition for shape {grid}")
            name = PAPER_PRESET[grid]
        if name not in PARTITION_PRESETS:
            known = ["paper", *PARTITION_PRESETS]
            raise bad("partition", name, f"unknown preset; use one of {known}")
        preset_grid, rule = PARTITION_PRESETS[name]
        if grid != preset_grid:
            raise bad("partition", name, f"preset is for shape {preset_grid}, not {grid}")
        return cls(shape, tuple(rule(x, y) for x, y in shape.voxels))

    @classmethod
    def from_grid(cls, text: str, shape: Shape | str) -> Partition:
        """Rows of one-character labels from the top, '.' for empty cells: ``AAABBB/AAABBB``."""
        shape = Shape.parse(shape) if isinstance(shape, str) else shape
        rows = [row.strip() for row in str(text).strip().split("/")]
        if len(rows) != shape.height or any(len(row) != shape.width for row in rows):
            raise bad(
                "partition", text,
                f"expected {shape.height} rows of {shape.width} labels like {shape.grid_string()}",
            )
        filled = set(shape.voxels)
        labels = {}
        for r, row in enumerate(rows):
            y = shape.height - 1 - r
            for x, char in enumerate(row):
                if (char == ".") != ((x, y) not in filled):
                    raise bad(
                        "partition", text, f"cell {(x, y)}: '.' exactly where the shape is empty"
                    )
                labels[(x, y)] = char
        return cls(shape, tuple(labels[v] for v in shape.voxels))

    @classmethod
    def parse(cls, spec: str, shape: Shape | str) -> Partition:
        """A preset name, a grid of labels, or the path of a partition file (``*.json``).

        See :meth:`preset`, :meth:`from_grid` and :meth:`load`; every command that takes a
        partition reads it through here.
        """
        spec = str(spec).strip()
        if spec.endswith(".json"):
            return cls.load(spec, shape)
        if spec == "paper" or spec in PARTITION_PRESETS:
            return cls.preset(spec, shape)
        return cls.from_grid(spec, shape)

    # -- the partition file ---------------------------------------------------------------------

    def to_dict(self, **notes) -> dict:
        """The file's JSON form (see the module docstring); ``notes`` are added as extra keys."""
        return {
            **PARTITION.header(),
            "shape": self.shape.grid_string(),
            "grid": self.grid_string(),
            "modules": {label: [list(v) for v in self.voxels_of(label)] for label in self.modules},
            **notes,
        }

    @classmethod
    def from_dict(
        cls, data: dict, shape: Shape | str | None = None, where: str = "partition data"
    ) -> Partition:
        """Inverse of :meth:`to_dict` (labels from ``modules``); with ``shape``, the data must
        be for that shape. ``where`` names the source in errors (a file's path)."""
        PARTITION.check(data, "partition", where)
        if not isinstance(data.get("shape"), str):
            raise bad("partition", where, f"shape={data.get('shape')!r}: expected a string "
                      "of rows of 1/0")
        saved = Shape.parse(data["shape"])
        if shape is not None:
            shape = Shape.parse(shape) if isinstance(shape, str) else shape
            if shape != saved:
                raise bad(
                    "partition", where,
                    f"is for shape {saved.grid_string()}, not {shape.grid_string()}",
                )
        label_of = _labels_of(data.get("modules"), saved, where)
        if len(label_of) != saved.n_voxels:
            missing = next(v for v in saved.voxels if v not in label_of)
            raise bad("partition", where, f"voxel {missing} is in no module; its modules must "
                      "cover the shape's voxels exactly")
        return cls(saved, tuple(label_of[v] for v in saved.voxels))

    def save(self, path: str | os.PathLike, **notes) -> Path:
        """Write the partition file (atomically); ``notes`` are added as extra keys."""
        text = json.dumps(self.to_dict(**notes), indent=1, allow_nan=False)
        return write_atomic(path, text + "\n")

    @classmethod
    def load(cls, path: str | os.PathLike, shape: Shape | str | None = None) -> Partition:
        """Read a partition file; with ``shape``, it must be for that shape."""
        data = read_json(path, "partition")
        return cls.from_dict(data, shape, str(path))

    @cached_property
    def modules(self) -> tuple[str, ...]:
        """The module labels, in the order of their first voxel."""
        return tuple(dict.fromkeys(self.labels))

    @cached_property
    def module_index(self) -> np.ndarray:
        """(V,) int64: for each voxel of the shape, its module's position in :attr:`modules`."""
        lookup = {label: i for i, label in enumerate(self.modules)}
        return np.array([lookup[label] for label in self.labels], dtype=np.int64)

    def voxels_of(self, label: str) -> tuple[tuple[int, int], ...]:
        """The voxels of module ``label``, in the shape's order."""
        if label not in self.labels:
            raise bad("module", label, f"not a module here; modules are {self.modules}")
        return tuple(v for v, m in zip(self.shape.voxels, self.labels) if m == label)

    def module_of(self, x: int, y: int) -> str:
        """The module of voxel (x, y)."""
        return self.labels[self.shape.index(x, y)]

    def same_module(self, voxel_a: tuple[int, int], voxel_b: tuple[int, int]) -> bool:
        """Whether two voxels, each (x, y), lie in the same module."""
        return self.module_of(*voxel_a) == self.module_of(*voxel_b)

    def grid_string(self) -> str:
        """Rows from the top, one character per cell ('.' empty), readable by :meth:`from_grid`.

        Labels longer than one character are written as letters A, B, ... in module order.
        """
        if all(len(label) == 1 for label in self.modules):
            char = {label: label for label in self.modules}
        else:
            char = {label: chr(ord("A") + i) for i, label in enumerate(self.modules)}
        cell = dict(zip(self.shape.voxels, self.labels))
        return "/".join(
            "".join(char[cell[(x, y)]] if (x, y) in cell else "." for x in range(self.shape.width))
            for y in reversed(range(self.shape.height))
        )


def _labels_of(modules, shape: Shape, where: str) -> dict[tuple[int, int], str]:
    """Voxel -> label from a file's ``modules`` ({label: [[x, y], ...]}), strict: each cell a
    pair of JSON integers (not bool, float or string), a voxel of ``shape``, in one module once.
    Errors name the file, then the cell's place and value."""
    if not isinstance(modules, dict):
        raise bad("partition", where, "expected modules as {label: [[x, y], ...]}")
    filled = set(shape.voxels)
    label_of: dict[tuple[int, int], str] = {}
    for label, cells in modules.items():
        if not isinstance(cells, list) or not cells:
            raise bad("partition", where,
                      f"modules[{label!r}]={_shown(cells)}: expected a non-empty list of [x, y]")
        for j, cell in enumerate(cells):
            place = f"modules[{label!r}][{j}]={_shown(cell)}"
            if (not isinstance(cell, list) or len(cell) != 2
                    or not all(type(c) is int for c in cell)):
                raise bad("partition", where, f"{place}: a cell is [x, y] with integer x and y")
            voxel = (cell[0], cell[1])
            if voxel not in filled:
                raise bad("partition", where,
                          f"{place}: not a voxel of shape {shape.grid_string()}")
            if voxel in label_of:
                other = label_of[voxel]
                again = "listed twice in this module" if other == label else (
                    f"also in module {other!r}")
                raise bad("partition", where, f"{place}: voxel {again}")
            label_of[voxel] = label
    return label_of


def _shown(value) -> str:
    """``value`` as an error shows it (cut when long, like :func:`~somite.errors.bad`)."""
    return str(bad("", value, "")).removeprefix("=").removesuffix(": ")
