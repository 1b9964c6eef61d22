"""Robot bodies: a shape (a grid of voxels) plus the sensors of each voxel.

Grid coordinates follow the paper's code (docs/original-system.md section 1.4): x to the right, y
up, y = 0 is the bottom row. Voxels are always listed row by row from the bottom (y outer, x inner),
and so are the sensor readings of a body: voxel by voxel, and inside a voxel sensor by sensor in the
order the voxel lists them (docs/original-system.md section 3). Controller nodes refer to readings
by their position in that list, so the order is part of the file format.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

from .. import checks
from ..errors import bad, bad_type
from ..formats import known_keys
from ..limits import MAX_SHAPE_SIDE
from .sensor_kinds import SENSORS

SENSOR_KINDS = tuple(kind.name for kind in SENSORS)
"""Sensor kinds, in the order in which a voxel lists them when it has several."""

SENSOR_WIDTH = {kind.name: kind.width for kind in SENSORS}
"""How many scalar readings one sensor of each kind gives."""


def voxel_readings(kinds: Iterable[str]) -> tuple[tuple[str, int], ...]:
    """(sensor kind, component) of each reading slot of a voxel with sensors ``kinds``.

    Sensor by sensor in the order given, component by component: a sensor node's ``slot`` is a
    position in this tuple. The one definition of a voxel's slots.
    """
    return tuple((kind, c) for kind in kinds for c in range(SENSOR_WIDTH[kind]))

PRESET_SHAPES = {
    "biped": "1111/1111/1001",
    "worm": "111111/111111",
}

_RECT = re.compile(r"^([0-9]+)x([0-9]+)$")
_GRID = re.compile(r"^[01]+(/[01]+)*$")
_MAX_DIGITS = 30
"""The most digits of W or H in ``WxH`` that are read (any more is refused unread)."""


@dataclass(frozen=True)
class Shape:
    """A 4-connected set of voxels on a grid.

    Attributes
    ----------
    width, height : int
        Grid size in voxels.
    voxels : tuple of (x, y)
        The filled cells, bottom row first, left to right inside a row.
    """

    width: int
    height: int
    voxels: tuple[tuple[int, int], ...]

    def __post_init__(self) -> None:
        if not self.voxels:
            raise bad("shape", self.grid_string(), "a shape needs at least one voxel")
        if not is_connected(set(self.voxels)):
            raise bad("shape", self.grid_string(), "voxels must be 4-connected")

    @classmethod
    def from_cells(cls, cells: Iterable[tuple[int, int]]) -> Shape:
        """Build a shape from any cells, translated so that the lowest x and y are 0."""
        cells = {(int(x), int(y)) for x, y in cells}
        if not cells:
            raise bad("shape", "", "a shape needs at least one voxel")
        x0 = min(x for x, _ in cells)
        y0 = min(y for _, y in cells)
        cells = {(x - x0, y - y0) for x, y in cells}
        width = max(x for x, _ in cells) + 1
        height = max(y for _, y in cells) + 1
        ordered = tuple(sorted(cells, key=lambda c: (c[1], c[0])))
        return cls(width, height, ordered)

    @classmethod
    def parse(cls, text: str) -> Shape:
        """Parse a preset name (``biped``, ``worm``), ``WxH``, or rows of 1/0 from the top."""
        spec = str(text).strip()
        spec = PRESET_SHAPES.get(spec, spec)
        match = _RECT.match(spec)
        if match:
            if max(len(match.group(1)), len(match.group(2))) > _MAX_DIGITS:
                # Not read: int() of thousands of digits is a ValueError (Python's limit).
                raise bad("shape", text, f"at most {MAX_SHAPE_SIDE} voxels a side "
                          "(somite.limits)")
            width, height = int(match.group(1)), int(match.group(2))
            if width < 1 or height < 1:
                raise bad("shape", text, "a rectangle needs a positive width and height")
            if max(width, height) > MAX_SHAPE_SIDE:
                raise bad("shape", text, f"at most {MAX_SHAPE_SIDE} voxels a side "
                          "(somite.limits)")
            spec = "/".join(["1" * width] * height)
        if not _GRID.match(spec):
            raise bad(
                "shape", text, "expected biped, worm, WxH or rows of 1/0 like 1111/1111/1001"
            )
        rows = spec.split("/")
        if len({len(row) for row in rows}) != 1:
            raise bad("shape", text, "all rows of a grid must have the same length")
        height = len(rows)
        if max(height, len(rows[0])) > MAX_SHAPE_SIDE:
            raise bad("shape", text, f"at most {MAX_SHAPE_SIDE} voxels a side (somite.limits)")
        cells = [
            (x, height - 1 - r) for r, row in enumerate(rows) for x, c in enumerate(row) if c == "1"
        ]
        if not cells:
            raise bad("shape", text, "a shape needs at least one voxel")
        return cls.from_cells(cells)

    def grid_string(self) -> str:
        """The rows of 1/0 from the top, e.g. ``1111/1111/1001`` for the biped."""
        filled = set(self.voxels)
        return "/".join(
            "".join("1" if (x, y) in filled else "0" for x in range(self.width))
            for y in reversed(range(self.height))
        )

    def index(self, x: int, y: int) -> int:
        """Index of voxel (x, y) in :attr:`voxels`; raises if the cell is empty."""
        try:
            return self.voxels.index((x, y))
        except ValueError:
            raise bad("voxel", (x, y), f"not a voxel of shape {self.grid_string()}") from None

    @property
    def n_voxels(self) -> int:
        return len(self.voxels)


def component(start: tuple[int, int], cells: set[tuple[int, int]]) -> set[tuple[int, int]]:
    """The cells of ``cells`` 4-connected to ``start`` (a flood fill)."""
    seen = {start}
    stack = [start]
    while stack:
        x, y = stack.pop()
        for n in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if n in cells and n not in seen:
                seen.add(n)
                stack.append(n)
    return seen


def is_connected(cells: set[tuple[int, int]]) -> bool:
    """Whether ``cells`` is non-empty and 4-connected."""
    return bool(cells) and len(component(next(iter(cells)), cells)) == len(cells)


def paper_sensors(shape: Shape) -> tuple[tuple[str, ...], ...]:
    """The paper's layout: area everywhere, touch on the bottom row, velocity on the top row,
    lidar on the rightmost column (docs/original-system.md section 2.2, on the grid's own
    rows)."""
    sensors = []
    for x, y in shape.voxels:
        kinds = ["area"]
        if y == 0:
            kinds.append("touch")
        if y == shape.height - 1:
            kinds.append("velocity")
        if x == shape.width - 1:
            kinds.append("lidar")
        sensors.append(tuple(kinds))
    return tuple(sensors)


SENSOR_PRESETS = {
    "paper": paper_sensors,
    "none": lambda shape: tuple(() for _ in shape.voxels),
    "area": lambda shape: tuple(("area",) for _ in shape.voxels),
    "all": lambda shape: tuple(SENSOR_KINDS for _ in shape.voxels),
}


@dataclass(frozen=True)
class Reading:
    """One scalar sensor reading of a body: which voxel, which sensor, which component."""

    voxel: int
    kind: str
    component: int


@dataclass(frozen=True)
class Body:
    """A shape and the sensors of each of its voxels (one tuple of kinds per voxel)."""

    shape: Shape
    sensors: tuple[tuple[str, ...], ...]

    def __post_init__(self) -> None:
        if len(self.sensors) != self.shape.n_voxels:
            raise bad(
                "sensors",
                len(self.sensors),
                f"need one sensor list per voxel ({self.shape.n_voxels} voxels)",
            )
        for voxel, kinds in zip(self.shape.voxels, self.sensors):
            for kind in kinds:
                if kind not in SENSOR_KINDS:
                    raise bad("sensor", kind, f"unknown sensor kind; use one of {SENSOR_KINDS}")
            if len(set(kinds)) != len(kinds):
                raise bad("sensors", kinds, f"voxel {voxel} lists a sensor twice")

    @classmethod
    def build(cls, shape: Shape | str, sensors: str | dict | None = "paper") -> Body:
        """A body from a shape (or shape string) and a preset name or a per-voxel mapping.

        ``sensors`` may be a preset (``paper``, ``none``, ``area``, ``all``) or a dict from
        (x, y) to a list of sensor kinds; voxels missing from the dict get no sensor.
        """
        if isinstance(shape, str):
            shape = Shape.parse(shape)
        checks.instance("shape", shape, Shape, "a shape name (worm, biped, WxH, rows of 1/0) "
                        "or a somite Shape")
        if sensors is None:
            sensors = "paper"
        if isinstance(sensors, str):
            if sensors not in SENSOR_PRESETS:
                raise bad("sensors", sensors, f"unknown preset; use one of {list(SENSOR_PRESETS)}")
            return cls(shape, SENSOR_PRESETS[sensors](shape))
        checks.instance("sensors", sensors, dict, "a preset name or a dict from (x, y) to "
                        "sensor kinds")
        per_voxel = {}
        for cell, kinds in sensors.items():
            if (not isinstance(cell, tuple) or len(cell) != 2
                    or not all(checks.is_integer(c) for c in cell)):
                raise bad_type("sensors", cell, "a voxel (x, y) of two integers as a key")
            if isinstance(kinds, str) or not isinstance(kinds, (list, tuple)):
                raise bad_type(f"sensors[{cell}]", kinds, "a list of sensor kinds")
            if not all(isinstance(k, str) for k in kinds):
                raise bad_type(f"sensors[{cell}]", kinds, "a list of sensor kinds (strings)")
            per_voxel[(int(cell[0]), int(cell[1]))] = tuple(kinds)
        for cell in per_voxel:
            shape.index(*cell)
        ordered = tuple(
            tuple(k for k in SENSOR_KINDS if k in per_voxel.get(v, ())) for v in shape.voxels
        )
        for kinds in per_voxel.values():
            for kind in kinds:
                if kind not in SENSOR_KINDS:
                    raise bad("sensor", kind, f"unknown sensor kind; use one of {SENSOR_KINDS}")
        return cls(shape, ordered)

    @cached_property
    def slots(self) -> tuple[tuple[tuple[str, int], ...], ...]:
        """Per voxel, its reading slots (see :func:`voxel_readings`)."""
        return tuple(voxel_readings(kinds) for kinds in self.sensors)

    @cached_property
    def readings(self) -> tuple[Reading, ...]:
        """Every scalar reading, in the body's stable order: voxel by voxel, slot by slot."""
        return tuple(
            Reading(v, kind, c) for v, slots in enumerate(self.slots) for kind, c in slots
        )

    @property
    def n_readings(self) -> int:
        return len(self.readings)

    def to_dict(self) -> dict:
        return {
            "shape": self.shape.grid_string(),
            "sensors": [
                {"x": x, "y": y, "kinds": list(kinds)}
                for (x, y), kinds in zip(self.shape.voxels, self.sensors)
            ],
        }

    @classmethod
    def from_dict(cls, data: dict) -> Body:
        """Inverse of :meth:`to_dict`, strict: the shape a string; ``sensors`` a preset name or
        a list of ``{x, y, kinds}`` whose x and y are JSON integers naming a voxel of the shape,
        each voxel at most once and each kind at most once in it (voxels not listed get no
        sensor). A voxel's kinds keep the file's order, which fixes what its slots mean."""
        if not isinstance(data, dict) or "shape" not in data:
            raise bad("body", data, "expected an object with 'shape' and 'sensors'")
        known_keys(data, ("shape", "sensors"), "body")
        if not isinstance(data["shape"], str):
            raise bad("body.shape", data["shape"],
                      "expected a string: biped, worm, WxH or rows of 1/0")
        shape = Shape.parse(data["shape"])
        sensors = data.get("sensors", "paper")
        if isinstance(sensors, str):
            return cls.build(shape, sensors)
        if not isinstance(sensors, list):
            raise bad("body.sensors", sensors, "expected a preset name or a list of {x, y, kinds}")
        per_voxel: dict[tuple[int, int], tuple[str, ...]] = {}
        filled = set(shape.voxels)
        for i, item in enumerate(sensors):
            cell = _sensor_cell(item, i, shape, filled)
            if cell in per_voxel:
                raise bad(f"body.sensors[{i}]", cell, "voxel listed twice")
            per_voxel[cell] = _sensor_kinds(item, i)
        return cls(shape, tuple(per_voxel.get(v, ()) for v in shape.voxels))


def _sensor_cell(item, i: int, shape: Shape, filled: set) -> tuple[int, int]:
    """The voxel (x, y) of ``body.sensors[i]``: integers (not bool, float, string) in ``shape``."""
    if not isinstance(item, dict) or not {"x", "y", "kinds"} <= item.keys():
        raise bad(f"body.sensors[{i}]", item, "expected {x, y, kinds}")
    known_keys(item, ("x", "y", "kinds"), f"body.sensors[{i}]")
    for axis in ("x", "y"):
        value = item[axis]
        if type(value) is not int:
            raise bad(f"body.sensors[{i}].{axis}", value, "voxel coordinates are JSON integers")
    cell = (item["x"], item["y"])
    if cell not in filled:
        raise bad(f"body.sensors[{i}]", cell, f"not a voxel of shape {shape.grid_string()}")
    return cell


def _sensor_kinds(item: dict, i: int) -> tuple[str, ...]:
    """The sensor kinds of ``body.sensors[i]``: known kinds, each once, in the file's order."""
    kinds = item["kinds"]
    if not isinstance(kinds, list):
        raise bad(f"body.sensors[{i}].kinds", kinds, f"expected a list of {SENSOR_KINDS}")
    for kind in kinds:
        if not isinstance(kind, str) or kind not in SENSOR_KINDS:
            raise bad(f"body.sensors[{i}].kinds", kind,
                      f"unknown sensor kind; use one of {SENSOR_KINDS}")
    if len(set(kinds)) != len(kinds):
        twice = next(kind for kind in kinds if kinds.count(kind) > 1)
        raise bad(f"body.sensors[{i}].kinds", twice, f"voxel {(item['x'], item['y'])} lists "
                  "this sensor twice")
    return tuple(kinds)
