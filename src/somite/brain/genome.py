"""The graph genome of a controller: nodes placed in voxels, weighted edges between them.

A node is a SENSOR (one scalar reading of its voxel), a HIDDEN node or an ACTUATOR (its voxel's
actuator); an edge u -> v carries a weight and a bias (docs/original-system.md sections 4.1, 3).
Nodes have stable integer ids in [0, 2**63) (:data:`MAX_NODE_ID` at most); positions in the
tuples mean nothing to the controller, which updates all nodes synchronously. The genome is
immutable: operators build new ones.

File format (JSON, strict: no NaN or Infinity)::

    {"format": "somite-genome", "version": 1, "body": {...},
     "nodes": [{"id": 0, "x": 0, "y": 0, "kind": "sensor", "slot": 0}, ...],
     "edges": [{"src": 0, "dst": 2, "weight": 0.31, "bias": -0.72}, ...]}

A genome with length-dependent delays (:mod:`somite.brain.delays`) also holds
``"delay_per_voxel": s``; one without holds no such key.

The compact form for logs has the same keys on one line, with each node written as
``[id, x, y, kind, slot]`` (slot null unless a sensor) and each edge as ``[src, dst, w, b]``.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .._io import parse_json, read_json, write_atomic
from ..errors import bad
from ..formats import GENOME, known_keys
from ..limits import MAX_WEIGHT
from ..sim.body import Body
from .delays import check_delay_per_voxel
from .kinds import ACTUATOR, HIDDEN, KIND_CODE, KIND_DTYPE, NODE_KINDS, SENSOR


@dataclass(frozen=True)
class Node:
    """A controller node in voxel (x, y).

    ``slot`` is, for a sensor, the index of its reading among its voxel's readings (0..k-1 in the
    body's order); it is None for hidden and actuator nodes.
    """

    id: int
    x: int
    y: int
    kind: str
    slot: int | None = None

    def to_dict(self) -> dict:
        """The node in a genome or module file (``slot`` only for a sensor)."""
        out = {"id": self.id, "x": self.x, "y": self.y, "kind": self.kind}
        if self.slot is not None:
            out["slot"] = self.slot
        return out


@dataclass(frozen=True)
class Edge:
    """A directed edge between node ids, with its weight and bias."""

    src: int
    dst: int
    weight: float
    bias: float

    @property
    def magnitude(self) -> float:
        """|w| + |b|: how much the edge weighs in the paper's cut ratio eta (eq. 5) and in
        module discovery."""
        return abs(self.weight) + abs(self.bias)

    def to_dict(self) -> dict:
        """The edge in a genome or module file."""
        return {"src": self.src, "dst": self.dst, "weight": float(self.weight),
                "bias": float(self.bias)}


class BodyTable(NamedTuple):
    """What a genome needs to know about its body, computed once per body."""

    voxel_index: dict  # (x, y) -> position in body.shape.voxels
    n_slots: tuple  # (V,) number of scalar readings of each voxel
    slot_count: np.ndarray  # (V,) int64, the same as an array
    first_reading: np.ndarray  # (V,) int64 index in body.readings of the voxel's slot 0
    voxel_xy: np.ndarray  # (V, 2) int64 voxel coordinates


@functools.lru_cache(maxsize=64)
def body_table(body: Body) -> BodyTable:
    """The reading table of ``body``; cached because every genome of a run shares one body."""
    n_slots = tuple(len(slots) for slots in body.slots)
    first = np.concatenate(([0], np.cumsum(n_slots)[:-1])).astype(np.int64)
    table = BodyTable(
        voxel_index={xy: i for i, xy in enumerate(body.shape.voxels)},
        n_slots=n_slots,
        slot_count=np.array(n_slots, dtype=np.int64),
        first_reading=first,
        voxel_xy=np.array(body.shape.voxels, dtype=np.int64).reshape(-1, 2),
    )
    # Shared by every genome of the body through the cache: nobody may write to it.
    for array in (table.slot_count, table.first_reading, table.voxel_xy):
        array.flags.writeable = False
    return table


class GenomeIndex(NamedTuple):
    """A genome as arrays over node positions (N nodes, E edges), for operators and compiling."""

    ids: np.ndarray  # (N,) int64 node ids
    kind: np.ndarray  # (N,) KIND_DTYPE codes SENSOR / HIDDEN / ACTUATOR
    voxel: np.ndarray  # (N,) int64 position of the node's voxel in body.shape.voxels
    slot: np.ndarray  # (N,) int64 sensor slot, -1 for other nodes
    src: np.ndarray  # (E,) int64 node position of each edge's source
    dst: np.ndarray  # (E,) int64 node position of each edge's target


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_real(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True, repr=False)
class Genome:
    """A graph controller for one body: its nodes and edges, validated on construction.

    Attributes
    ----------
    body : Body
        The body the controller drives; nodes refer to its voxels and readings.
    nodes : tuple of Node
        Every reading of the body has exactly one sensor node and every voxel one actuator node;
        hidden nodes come on top.
    edges : tuple of Edge
        No edge leaves an actuator or enters a sensor; at most one edge per ordered pair.
    """

    body: Body
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]
    delay_per_voxel: float = 0.0
    """Control steps of delay per voxel of an edge's length (:mod:`somite.brain.delays`); 0, the
    default, is the paper's one step for every edge. A genome carries it, so that it runs the
    same wherever it is evaluated; its file holds it only when it is not 0."""

    def __post_init__(self) -> None:
        if not isinstance(self.body, Body):
            raise bad("body", type(self.body).__name__, "expected a somite Body")
        object.__setattr__(self, "delay_per_voxel",
                           check_delay_per_voxel("delay_per_voxel", self.delay_per_voxel))
        # Accept lists for convenience; the stored form must be hashable.
        object.__setattr__(self, "nodes", tuple(self.nodes))
        object.__setattr__(self, "edges", tuple(self.edges))
        position, index = _validate(self.nodes, self.edges, body_table(self.body))
        # Not fields: derived data, left out of equality, hashing and the file.
        object.__setattr__(self, "_position", position)
        object.__setattr__(self, "_index", index)

    def __repr__(self) -> str:
        return (
            f"Genome(body={self.body.shape.grid_string()!r}, n_nodes={self.n_nodes}, "
            f"n_edges={self.n_edges})"
        )

    @property
    def n_nodes(self) -> int:
        """|V|, the number of nodes."""
        return len(self.nodes)

    @property
    def size(self) -> int:
        """|G| = |V| + |E| (docs/original-system.md section 4.1)."""
        return len(self.nodes) + len(self.edges)

    @property
    def n_edges(self) -> int:
        """|E|, the number of edges."""
        return len(self.edges)

    @property
    def position(self) -> dict[int, int]:
        """Node id -> position in :attr:`nodes`."""
        return self._position

    @property
    def index(self) -> GenomeIndex:
        """The genome as arrays over node positions, for operators and compiling."""
        return self._index

    # -- serialisation ------------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The JSON-ready form (see the module docstring)."""
        return {
            **GENOME.header(),
            "body": self.body.to_dict(),
            "nodes": [n.to_dict() for n in self.nodes],
            "edges": [e.to_dict() for e in self.edges],
            **self._delay_dict(),
        }

    def _delay_dict(self) -> dict:
        # Only when set: the paper's genomes keep the files (and digests) they always had.
        return {"delay_per_voxel": self.delay_per_voxel} if self.delay_per_voxel else {}

    @classmethod
    def from_dict(cls, data: dict) -> Genome:
        """Inverse of :meth:`to_dict`; also reads the compact form's list rows."""
        GENOME.check(data)
        known_keys(data, ("format", "version", "body", "nodes", "edges", "delay_per_voxel"), "")
        if "body" not in data:
            raise bad("body", None, "a genome file needs the body it was evolved for")
        body = Body.from_dict(data["body"])
        nodes = [_node_from(item, i) for i, item in enumerate(_rows(data, "nodes"))]
        edges = [_edge_from(item, i) for i, item in enumerate(_rows(data, "edges"))]
        return cls(body, tuple(nodes), tuple(edges), data.get("delay_per_voxel", 0.0))

    def to_compact(self) -> str:
        """One line of JSON for logs; :meth:`from_compact` reads it back exactly."""
        data = self.to_dict()
        data["nodes"] = [[n.id, n.x, n.y, n.kind, n.slot] for n in self.nodes]
        data["edges"] = [[e.src, e.dst, float(e.weight), float(e.bias)] for e in self.edges]
        return json.dumps(data, allow_nan=False, separators=(",", ":"))

    @classmethod
    def from_compact(cls, text: str) -> Genome:
        """Read the output of :meth:`to_compact` (or any genome JSON text)."""
        if not isinstance(text, (str, bytes, bytearray)):
            raise bad("genome", type(text).__name__, "expected JSON text")
        return cls.from_dict(parse_json(text, "genome", text))

    def save(self, path: str | os.PathLike) -> Path:
        """Write the genome as JSON; atomic (temp file in the same folder, then rename)."""
        text = json.dumps(self.to_dict(), allow_nan=False, indent=1)
        return write_atomic(path, text + "\n")

    @classmethod
    def load(cls, path: str | os.PathLike) -> Genome:
        """Read a genome file written by :meth:`save`."""
        return cls.from_dict(read_json(path, "genome"))


MAX_NODE_ID = 2**63 - 1
"""The largest node id (ids are in [0, 2**63), the range of the int64 arrays they are kept in)."""


def next_id(genome: Genome) -> int:
    """A fresh node id for a new hidden node: the largest id plus one (see :func:`fresh_ids`)."""
    return fresh_ids(genome.position, 1)[0]


def fresh_ids(used: Iterable[int], count: int) -> list[int]:
    """``count`` node ids not in ``used``: the ones just above the largest used id or, when
    those would pass :data:`MAX_NODE_ID` (the largest is a valid id, so one plus it may not
    fit), the smallest unused ones. Every valid genome can grow, and no id overflows."""
    used = set(used)
    largest = max(used, default=-1)
    if largest + count <= MAX_NODE_ID:
        return list(range(largest + 1, largest + 1 + count))
    free = (i for i in range(len(used) + count) if i not in used)
    return [next(free) for _ in range(count)]


# -- validation ---------------------------------------------------------------------------------
#
# Genomes are built on every mutation, so validation runs a vectorised check first; only when
# that fails does the item-by-item check run, to say which field is wrong.

_NONE = type(None)


def _validate(nodes, edges, table: BodyTable) -> tuple[dict[int, int], GenomeIndex]:
    """Check nodes and edges against the body; return id -> position and the index arrays."""
    fast = _fast_index(nodes, edges, table)
    if fast is not None:
        return fast
    position, kinds, voxels, slots = _check_nodes(nodes, table)
    src, dst = _check_edges(edges, position, kinds)
    return position, _frozen(GenomeIndex(
        ids=np.array([n.id for n in nodes], dtype=np.int64),
        kind=np.array(kinds, dtype=KIND_DTYPE),
        voxel=np.array(voxels, dtype=np.int64),
        slot=np.array(slots, dtype=np.int64),
        src=np.array(src, dtype=np.int64),
        dst=np.array(dst, dtype=np.int64),
    ))


def _frozen(index: GenomeIndex) -> GenomeIndex:
    """The same arrays, read-only: the index belongs to an immutable genome."""
    for array in index:
        array.flags.writeable = False
    return index


def _fast_index(nodes, edges, table: BodyTable):
    """The vectorised check: (position, index) for a valid genome, None for any problem."""
    if not all(type(n) is Node for n in nodes) or not all(type(e) is Edge for e in edges):
        return None
    ids = [n.id for n in nodes]
    xs = [n.x for n in nodes]
    ys = [n.y for n in nodes]
    slots = [n.slot for n in nodes]
    # Exact types, before any lookup: bools and floats hash like ints and would slip through,
    # and a list or dict cannot be looked up at all.
    if not {*map(type, ids), *map(type, xs), *map(type, ys)} <= {int}:
        return None
    if not {type(n.kind) for n in nodes} <= {str}:
        return None
    codes = [KIND_CODE.get(n.kind) for n in nodes]
    voxels = [table.voxel_index.get(xy) for xy in zip(xs, ys)]
    if None in codes or None in voxels or not set(map(type, slots)) <= {int, _NONE}:
        return None
    position = dict(zip(ids, range(len(ids))))
    if len(position) != len(ids) or (ids and min(ids) < 0):
        return None
    kind = np.array(codes, dtype=KIND_DTYPE)
    voxel = np.array(voxels, dtype=np.int64)
    try:
        slot = np.array([-1 if s is None else s for s in slots], dtype=np.int64)
        np.array(ids, dtype=np.int64)
    except OverflowError:  # an integer of many digits: the item-by-item check names it
        return None
    if not _nodes_cover_body(kind, voxel, slot, [s is None for s in slots], table):
        return None
    edge_columns = _fast_edges(edges, position, kind)
    if edge_columns is None:
        return None
    ids_arr = np.array(ids, dtype=np.int64)
    return position, _frozen(GenomeIndex(ids_arr, kind, voxel, slot, *edge_columns))


def _nodes_cover_body(kind, voxel, slot, slot_is_none, table: BodyTable) -> bool:
    """Slots where they belong and in range; each reading and each actuator exactly once."""
    sensor = kind == SENSOR
    if np.any(np.array(slot_is_none, dtype=bool) == sensor):
        return False
    sensor_voxel, sensor_slot = voxel[sensor], slot[sensor]
    if np.any(sensor_slot < 0) or np.any(sensor_slot >= table.slot_count[sensor_voxel]):
        return False
    readings = np.sort(table.first_reading[sensor_voxel] + sensor_slot)
    actuated = np.sort(voxel[kind == ACTUATOR])
    return np.array_equal(readings, np.arange(sum(table.n_slots))) and np.array_equal(
        actuated, np.arange(len(table.n_slots))
    )


def _fast_edges(edges, position: dict, kind: np.ndarray):
    """(src, dst) node positions of valid edges, or None for any problem."""
    if not edges:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    srcs = [e.src for e in edges]
    dsts = [e.dst for e in edges]
    params = [e.weight for e in edges] + [e.bias for e in edges]
    if not {*map(type, srcs), *map(type, dsts)} <= {int}:
        return None
    if not set(map(type, params)) <= {float, int, np.float64}:
        return None
    u = [position.get(i) for i in srcs]
    v = [position.get(i) for i in dsts]
    if None in u or None in v or not all(abs(p) <= MAX_WEIGHT for p in params):
        return None
    if len(set(zip(u, v))) != len(u):
        return None
    u = np.array(u, dtype=np.int64)
    v = np.array(v, dtype=np.int64)
    if np.any(kind[u] == ACTUATOR) or np.any(kind[v] == SENSOR):
        return None
    return u, v


def _check_nodes(nodes, table: BodyTable):
    """Validate the nodes; return id -> position and the per-node kind, voxel and slot columns."""
    position: dict[int, int] = {}
    kinds, voxels, slots = [], [], []
    seen_readings: set[tuple[int, int]] = set()
    actuated: set[int] = set()
    for i, node in enumerate(nodes):
        if not isinstance(node, Node):
            raise bad(f"nodes[{i}]", node, "expected a Node")
        if not _is_int(node.id) or not 0 <= node.id <= MAX_NODE_ID:
            raise bad(f"nodes[{i}].id", node.id, "node ids must be integers in [0, 2**63)")
        if node.id in position:
            raise bad(f"nodes[{i}].id", node.id, "node ids must be unique")
        try:
            kind = KIND_CODE[node.kind]
        except (KeyError, TypeError):
            raise bad(f"nodes[{i}].kind", node.kind, f"use one of {NODE_KINDS}") from None
        voxel = None
        if _is_int(node.x) and _is_int(node.y):
            voxel = table.voxel_index.get((node.x, node.y))
        if voxel is None:
            raise bad(f"nodes[{i}]", (node.x, node.y), "not a voxel of the body")
        if kind == SENSOR:
            slot = node.slot
            if not _is_int(slot) or not 0 <= slot < table.n_slots[voxel]:
                raise bad(
                    f"nodes[{i}].slot", slot,
                    f"voxel {(node.x, node.y)} has readings 0..{table.n_slots[voxel] - 1}",
                )
            if (voxel, slot) in seen_readings:
                raise bad(f"nodes[{i}].slot", slot, f"voxel {(node.x, node.y)} reads it twice")
            seen_readings.add((voxel, slot))
        else:
            if node.slot is not None:
                raise bad(f"nodes[{i}].slot", node.slot, f"a {node.kind} node has no slot")
            slot = -1
            if kind == ACTUATOR:
                if voxel in actuated:
                    raise bad(f"nodes[{i}]", (node.x, node.y), "voxel has two actuator nodes")
                actuated.add(voxel)
        position[node.id] = i
        kinds.append(kind)
        voxels.append(voxel)
        slots.append(slot)
    _check_coverage(table, seen_readings, actuated)
    return position, kinds, voxels, slots


def _check_coverage(table: BodyTable, seen_readings: set, actuated: set) -> None:
    """Every reading and every actuator of the body must have its node."""
    n_voxels = len(table.n_slots)
    if len(actuated) != n_voxels:
        missing = min(set(range(n_voxels)) - actuated)
        raise bad("nodes", tuple(table.voxel_xy[missing].tolist()), "voxel has no actuator node")
    if len(seen_readings) != sum(table.n_slots):
        for voxel, count in enumerate(table.n_slots):
            for slot in range(count):
                if (voxel, slot) not in seen_readings:
                    xy = tuple(table.voxel_xy[voxel].tolist())
                    raise bad("nodes", xy, f"voxel has no sensor node for reading slot {slot}")


def _check_edges(edges, position: dict, kinds: list):
    """Validate the edges; return the node positions of their sources and targets."""
    src, dst = [], []
    pairs: set[tuple[int, int]] = set()
    for i, edge in enumerate(edges):
        if not isinstance(edge, Edge):
            raise bad(f"edges[{i}]", edge, "expected an Edge")
        u = position.get(edge.src) if _is_int(edge.src) else None
        v = position.get(edge.dst) if _is_int(edge.dst) else None
        if u is None:
            raise bad(f"edges[{i}].src", edge.src, "no node has this id")
        if v is None:
            raise bad(f"edges[{i}].dst", edge.dst, "no node has this id")
        if kinds[u] == ACTUATOR:
            raise bad(f"edges[{i}].src", edge.src, "an edge cannot leave an actuator node")
        if kinds[v] == SENSOR:
            raise bad(f"edges[{i}].dst", edge.dst, "an edge cannot enter a sensor node")
        if (u, v) in pairs:
            raise bad(f"edges[{i}]", (edge.src, edge.dst), "duplicate edge")
        for name in ("weight", "bias"):
            value = getattr(edge, name)
            # Compared, not converted: an integer of 400 digits overflows a float.
            if not _is_real(value) or not abs(value) <= MAX_WEIGHT:
                raise bad(f"edges[{i}].{name}", value,
                          f"must be a number of magnitude at most {MAX_WEIGHT:g} (somite.limits)")
        pairs.add((u, v))
        src.append(u)
        dst.append(v)
    return src, dst


# -- JSON helpers -------------------------------------------------------------------------------


NODE_KEYS = ("id", "x", "y", "kind", "slot")
"""The keys of a node in a genome or module file."""
EDGE_KEYS = ("src", "dst", "weight", "bias")
"""The keys of an edge in a genome or module file."""


def _rows(data: dict, key: str) -> list:
    rows = data.get(key)
    if not isinstance(rows, list):
        raise bad(key, rows, "expected a list")
    return rows


def _node_from(item, i: int) -> Node:
    known_keys(item, NODE_KEYS, f"nodes[{i}]")
    try:
        if isinstance(item, list):
            node_id, x, y, kind, slot = item
            return Node(node_id, x, y, kind, slot)
        return Node(item["id"], item["x"], item["y"], item["kind"], item.get("slot"))
    except (KeyError, TypeError, ValueError, AttributeError):
        raise bad(f"nodes[{i}]", item, "expected {id, x, y, kind[, slot]}") from None


def _edge_from(item, i: int) -> Edge:
    known_keys(item, EDGE_KEYS, f"edges[{i}]")
    try:
        if isinstance(item, list):
            src, dst, weight, bias = item
            return Edge(src, dst, weight, bias)
        return Edge(item["src"], item["dst"], item["weight"], item["bias"])
    except (KeyError, TypeError, ValueError, AttributeError):
        raise bad(f"edges[{i}]", item, "expected {src, dst, weight, bias}") from None


__all__ = [
    "ACTUATOR",
    "HIDDEN",
    "MAX_NODE_ID",
    "NODE_KINDS",
    "SENSOR",
    "BodyTable",
    "Edge",
    "Genome",
    "GenomeIndex",
    "Node",
    "body_table",
    "fresh_ids",
    "next_id",
]
