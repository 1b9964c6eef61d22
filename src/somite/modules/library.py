"""A library of modules: module files, listing a folder, and assembling robots from modules.

The paper envisions "libraries of pre-optimized modules that can be reused over and over" and new
robots "assembled from modules picked from a repository" (sections 5.3 and 6). A module file holds
one :class:`~somite.modules.module.Module` with its coordinates relative to its own bounding-box
corner, plus where it came from. File format (JSON, strict: no NaN or Infinity)::

    {"format": "somite-module", "version": 1, "label": "front",
     "voxels": [{"x": 0, "y": 0, "sensors": ["area", "touch"]}, ...],
     "nodes": [{"id": 9, "x": 0, "y": 0, "kind": "sensor", "slot": 0}, ...],
     "edges": [{"src": 9, "dst": 11, "weight": 0.31, "bias": -0.72}, ...],
     "provenance": {"donor": "runs/w3/best.json", "donor_shape": "111111/111111",
                    "module": "front", "partition": "AAABBB/AAABBB", "origin": [3, 0],
                    "donor_velocity": 1.93}}

Node ids are the donor's. ``sensors`` lists a voxel's sensor kinds in the donor body's order,
which fixes what each sensor slot means. ``donor_velocity`` is null when unknown. A module's name
in a library is its file name without ``.json``; a library folder holds module files only.

Assembly (:func:`assemble`) places modules at grid offsets: module voxel (x, y), relative to the
module's corner, goes to (x + X, y + Y) for placement ``NAME@X,Y``. The body is the union of the
placed voxels, each keeping its module's sensors; the controller is the modules' nodes and internal
edges, with no edge between modules. Every module carries one actuator node per voxel, so every
voxel of the result is actuated.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from .._io import read_json, write_atomic
from ..brain.genome import EDGE_KEYS, NODE_KEYS, Edge, Genome, Node
from ..errors import SomiteError, bad
from ..formats import MODULE, known_keys
from ..limits import MAX_SHAPE_SIDE
from ..sim.body import SENSOR_KINDS, Body, Shape, component, is_connected
from .graft import Graft, graft
from .module import Module

_PLACE = re.compile(r"^([^@]+)@(-?\d+),(-?\d+)$")


@dataclass(frozen=True)
class Provenance:
    """Where a library module comes from.

    Attributes
    ----------
    donor : str or None
        The donor genome's file, as given when exporting.
    donor_shape : str
        The donor's shape as a grid string (rows from the top).
    module : str
        The module's label in the donor's partition.
    partition : str
        The donor's partition as a grid of labels.
    origin : (x, y)
        Where the module's bounding-box corner sat in the donor.
    donor_velocity : float or None
        The donor's v_x [m/s], when known.
    """

    donor: str | None
    donor_shape: str
    module: str
    partition: str
    origin: tuple[int, int]
    donor_velocity: float | None = None

    def to_dict(self) -> dict:
        return {
            "donor": self.donor,
            "donor_shape": self.donor_shape,
            "module": self.module,
            "partition": self.partition,
            "origin": list(self.origin),
            "donor_velocity": self.donor_velocity,
        }


@dataclass(frozen=True, repr=False)
class LibraryModule:
    """A module of a library: its name, the module (corner at (0, 0)) and its provenance."""

    name: str
    module: Module
    provenance: Provenance
    path: str | None = None

    def __repr__(self) -> str:
        return f"LibraryModule({self.name!r}, {self.module!r})"

    def summary(self) -> dict:
        """What ``somite module list`` shows: name, size, sensors, donor, v_x, graph size."""
        counts = {
            kind: sum(kind in kinds for kinds in self.module.sensors) for kind in SENSOR_KINDS
        }
        return {
            "name": self.name,
            "size": self.module.size,
            "shape": self.module.genome().body.shape.grid_string(),
            "sensors": {kind: n for kind, n in counts.items() if n},
            "nodes": len(self.module.nodes),
            "edges": len(self.module.edges),
            "donor": self.provenance.donor,
            "donor_shape": self.provenance.donor_shape,
            "module": self.provenance.module,
            "v_x": self.provenance.donor_velocity,
        }


def provenance_of(
    module: Module,
    donor: Genome,
    partition_grid: str,
    donor_file: str | None = None,
    donor_velocity: float | None = None,
) -> Provenance:
    """The provenance of ``module`` cut from ``donor`` (partition given as its grid string)."""
    if donor_velocity is not None and not math.isfinite(donor_velocity):
        raise bad("velocity", donor_velocity, "must be a finite number")
    return Provenance(
        donor=donor_file,
        donor_shape=donor.body.shape.grid_string(),
        module=module.label,
        partition=partition_grid,
        origin=module.origin,
        donor_velocity=None if donor_velocity is None else float(donor_velocity),
    )


# -- files ----------------------------------------------------------------------------------------


def module_to_dict(module: Module, provenance: Provenance) -> dict:
    """The JSON form of a module file (see the module docstring); coordinates made relative."""
    module = module.relative()
    return {
        **MODULE.header(),
        "label": module.label,
        "voxels": [
            {"x": x, "y": y, "sensors": list(kinds)}
            for (x, y), kinds in zip(module.voxels, module.sensors)
        ],
        "nodes": [n.to_dict() for n in module.nodes],
        "edges": [e.to_dict() for e in module.edges],
        "provenance": provenance.to_dict(),
    }


def module_from_dict(data, name: str, path: str | None = None) -> LibraryModule:
    """Read the JSON form of a module file; one-line errors for anything malformed."""
    MODULE.check(data)
    known_keys(data, ("format", "version", "label", "voxels", "nodes", "edges", "provenance"),
               "")
    for key, allowed in (("voxels", ("x", "y", "sensors")), ("nodes", NODE_KEYS),
                         ("edges", EDGE_KEYS)):
        for i, item in enumerate(data.get(key) if isinstance(data.get(key), list) else []):
            known_keys(item, allowed, f"{key}[{i}]")
    try:
        voxels = [(item["x"], item["y"]) for item in _list(data, "voxels")]
        sensors = [_kinds(item["sensors"]) for item in data["voxels"]]
        nodes = [
            Node(item["id"], item["x"], item["y"], item["kind"], item.get("slot"))
            for item in _list(data, "nodes")
        ]
        edges = [
            Edge(item["src"], item["dst"], item["weight"], item["bias"])
            for item in _list(data, "edges")
        ]
    except (KeyError, TypeError, AttributeError) as error:
        raise bad("module", name, f"malformed voxel, node or edge ({error!r})") from None
    for i, (x, y) in enumerate(voxels):
        if type(x) is not int or type(y) is not int:
            raise bad(f"voxels[{i}]", (x, y), "voxel coordinates are integers")
    _check_span(voxels)
    for i, node in enumerate(nodes):
        if type(node.x) is not int or type(node.y) is not int:
            raise bad(f"nodes[{i}]", (node.x, node.y), "node coordinates are integers")
    label = data.get("label", name)
    if not isinstance(label, str):
        raise bad("label", label, "expected the module's name, a string")
    provenance = _provenance_from(data.get("provenance", {}))
    module = Module(label, tuple(voxels), tuple(sensors), nodes, edges)
    return LibraryModule(name, module, provenance, path)


def _check_span(voxels: list) -> None:
    """Refuse a module wider or taller than any body may be (it could never be placed)."""
    if not voxels:
        return  # Module's own check says that a module needs a voxel
    width = max(x for x, _ in voxels) - min(x for x, _ in voxels) + 1
    height = max(y for _, y in voxels) - min(y for _, y in voxels) + 1
    if max(width, height) > MAX_SHAPE_SIDE:
        raise bad("voxels", f"{width}x{height}",
                  f"a module spans at most {MAX_SHAPE_SIDE} voxels a side (somite.limits)")


def _kinds(value) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(kind, str) for kind in value):
        raise bad("voxels.sensors", value, "expected a list of sensor kinds")
    return tuple(value)


def _list(data: dict, key: str) -> list:
    rows = data.get(key)
    if not isinstance(rows, list):
        raise bad(key, rows, "expected a list")
    return rows


def _provenance_from(data) -> Provenance:
    """The ``provenance`` object, strict: strings where strings belong, ``origin`` two JSON
    integers, ``donor_velocity`` a finite number or null (JSON's NaN, Infinity and 1e999 are
    refused, as is an integer too large for a float)."""
    if not isinstance(data, dict):
        raise bad("provenance", data, "expected an object")
    origin = data.get("origin", [0, 0])
    if not (isinstance(origin, list) and len(origin) == 2
            and all(type(c) is int for c in origin)):
        raise bad("provenance.origin", origin, "expected [x, y], two integers")
    donor = data.get("donor")
    if donor is not None and not isinstance(donor, str):
        raise bad("provenance.donor", donor, "expected the donor's file name or null")
    texts = {key: data.get(key, "") for key in ("donor_shape", "module", "partition")}
    for key, value in texts.items():
        if not isinstance(value, str):
            raise bad(f"provenance.{key}", value, "expected a string")
    return Provenance(
        donor=donor,
        origin=(origin[0], origin[1]),
        donor_velocity=_velocity(data.get("donor_velocity")),
        **texts,
    )


def _velocity(value) -> float | None:
    """``provenance.donor_velocity`` as a float: a finite number, or None for null."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise bad("provenance.donor_velocity", value, "must be a number or null")
    try:
        velocity = float(value)
    except OverflowError:  # an integer of hundreds of digits
        velocity = math.inf
    if not math.isfinite(velocity):
        raise bad("provenance.donor_velocity", value, "must be a finite number or null")
    return velocity


def module_text(module: Module, provenance: Provenance) -> str:
    """The text of a module file."""
    return json.dumps(module_to_dict(module, provenance), allow_nan=False, indent=1) + "\n"


def export_module(module: Module, path: str | os.PathLike, provenance: Provenance) -> Path:
    """Write ``module`` as a module file at ``path`` (atomically)."""
    path = Path(path)
    write_atomic(path, module_text(module, provenance))
    return path


def load_module(path: str | os.PathLike) -> LibraryModule:
    """Read a module file; its library name is the file name without ``.json``."""
    path = Path(path)
    data = read_json(path, "module")
    try:
        return module_from_dict(data, _name_of(path), str(path))
    except SomiteError as error:
        # Say which file: a library folder holds many.
        raise bad("module", str(path), str(error)) from None


def _name_of(path: Path) -> str:
    return path.name[: -len(".json")] if path.name.endswith(".json") else path.name


def list_library(
    sources: str | os.PathLike | Iterable[str | os.PathLike],
) -> tuple[LibraryModule, ...]:
    """The modules of a library folder (every ``*.json`` in it) and/or of module files.

    Returns them sorted by name; two modules with the same name are an error.
    """
    if isinstance(sources, (str, os.PathLike)):
        sources = [sources]
    paths: list[Path] = []
    for source in sources:
        source = Path(source)
        try:
            if source.is_dir():
                paths.extend(sorted(source.glob("*.json")))
            elif source.is_file():
                paths.append(source)
            else:
                raise bad("library", str(source), "no such folder or module file")
        except OSError as error:  # a name too long for the file system, an unreadable folder
            raise bad("library", str(source), f"cannot read it ({error.strerror})") from None
    modules: dict[str, LibraryModule] = {}
    for path in paths:
        item = load_module(path)
        if item.name in modules:
            first = modules[item.name].path
            raise bad("module", item.name, f"two modules have this name: {first}, {path}")
        modules[item.name] = item
    return tuple(modules[name] for name in sorted(modules))


# -- assembly -------------------------------------------------------------------------------------


@dataclass(frozen=True, repr=False)
class Placement:
    """Put library module ``module`` with its bounding-box corner at grid cell (x, y)."""

    module: LibraryModule
    x: int
    y: int

    def __repr__(self) -> str:
        return f"Placement({self.text})"

    @property
    def text(self) -> str:
        """``NAME@X,Y``, as written on the command line."""
        return f"{self.module.name}@{self.x},{self.y}"


def parse_placement(text: str, library: Sequence[LibraryModule], field: str = "place") -> Placement:
    """Read ``NAME@X,Y`` against the modules of ``library``."""
    match = _PLACE.match(str(text).strip())
    if not match:
        raise bad(field, text, "expected NAME@X,Y, e.g. front@3,0")
    name, x, y = match.group(1), int(match.group(2)), int(match.group(3))
    by_name = {item.name: item for item in library}
    if name not in by_name:
        raise bad(field, text, f"no module {name!r} in the library; it has {sorted(by_name)}")
    return Placement(by_name[name], x, y)


def assemble(placements: Sequence[Placement]) -> Genome:
    """A new robot made of library modules placed on a grid (see the module docstring).

    Parameters
    ----------
    placements : sequence of Placement
        The modules and where their corners go; they may not overlap, their union must be
        4-connected and at most :data:`~somite.limits.MAX_SHAPE_SIDE` voxels a side.

    Returns
    -------
    Genome
        The controller, on a body whose grid is the placed voxels moved so that the lowest x and y
        are 0. Hidden nodes left without edges are pruned.
    """
    if not placements:
        raise bad("place", [], "place at least one module")
    owner: dict[tuple[int, int], int] = {}
    offsets = []
    for i, placement in enumerate(placements):
        if not isinstance(placement, Placement):
            raise bad(f"place[{i}]", placement, "expected a Placement")
        x0, y0 = placement.module.module.origin
        dx, dy = placement.x - x0, placement.y - y0
        for x, y in placement.module.module.voxels:
            cell = (x + dx, y + dy)
            if cell in owner:
                other = placements[owner[cell]].text
                raise bad(
                    f"place[{i}]", placement.text,
                    f"overlaps place[{owner[cell]}]={other!r} at voxel {cell}",
                )
            owner[cell] = i
        offsets.append((dx, dy))
        _check_size(placements, i, owner)
    _check_connected(placements, owner)
    return _build(placements, owner, offsets)


def _check_size(placements: Sequence[Placement], i: int, owner: dict) -> None:
    """Refuse ``place[i]`` when, with the placements before it, the body would be wider or
    taller than :data:`~somite.limits.MAX_SHAPE_SIDE` (which every other command refuses)."""
    xs = [x for x, _ in owner]
    ys = [y for _, y in owner]
    width, height = max(xs) - min(xs) + 1, max(ys) - min(ys) + 1
    if max(width, height) > MAX_SHAPE_SIDE:
        raise bad(
            f"place[{i}]", placements[i].text,
            f"the assembled body would span {width}x{height} voxels; at most {MAX_SHAPE_SIDE} "
            "a side (somite.limits)",
        )


def _check_connected(placements: Sequence[Placement], owner: dict) -> None:
    if is_connected(set(owner)):
        return
    start = next(cell for cell, i in owner.items() if i == 0)
    reached = component(start, set(owner))
    i = min(j for cell, j in owner.items() if cell not in reached)
    raise bad(
        f"place[{i}]", placements[i].text,
        "does not touch place[0] (directly or through other modules); "
        "the placed modules must form one 4-connected body",
    )


def _build(placements: Sequence[Placement], owner: dict, offsets: list) -> Genome:
    """The body from the placed voxels, then the modules grafted onto it."""
    shape = Shape.from_cells(owner)
    # Shape.from_cells moved the cells so that the lowest x and y are 0; move the modules too.
    sx = min(x for x, _ in owner)
    sy = min(y for _, y in owner)
    sensors = []
    for x, y in shape.voxels:
        i = owner[(x + sx, y + sy)]
        module = placements[i].module.module
        dx, dy = offsets[i]
        sensors.append(module.sensors[module.voxels.index((x + sx - dx, y + sy - dy))])
    # Body() directly, not Body.build: build would sort the kinds and so renumber the slots.
    body = Body(shape, tuple(sensors))
    steps = []
    for i, (placement, (dx, dy)) in enumerate(zip(placements, offsets)):
        module = placement.module.module
        offset = (dx - sx, dy - sy)
        target = tuple((x + offset[0], y + offset[1]) for x, y in module.voxels)
        steps.append(Graft(f"place[{i}]", module, offset, target))
    genome, _ = graft(body, steps)
    return genome


__all__ = [
    "LibraryModule",
    "Placement",
    "Provenance",
    "assemble",
    "export_module",
    "list_library",
    "load_module",
    "module_from_dict",
    "module_text",
    "module_to_dict",
    "parse_placement",
    "provenance_of",
]
