"""Controller types by table: a batch's controllers packed into arrays (:class:`Controllers`)
and the compiled call that runs robot b's controller at a control step (:func:`control`).

A controller type is a row of :data:`CONTROLLER_TYPES` (its specification class, from
:mod:`somite.brain.controllers`, and the function that packs a batch's specifications of that
type into its fields of :class:`Controllers`) and a branch of :func:`control`. Its code, what
``Controllers.kind`` holds, is its position in the table. The episode kernel
(:mod:`somite.tasks.episode`) calls :func:`control` once a control step, whatever the type.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from .._arrays import pad
from .._jit import uncounted
from ..errors import bad, bad_type
from .controllers import GraphArrays, Sine, Table, Zero
from .kernels import Graph, graph_step
from .openloop import sine_actuation, table_actuation

class Controllers(NamedTuple):
    """Controllers of a batch, padded (N nodes, E edges, L table rows)."""

    kind: np.ndarray  # (B,) int32 ZERO / SINE / TABLE / GRAPH
    sine: np.ndarray  # (B, 3) freq [Hz], amp, phase [rad per voxel column]
    table: np.ndarray  # (B, L, V) actuation rows
    table_period: np.ndarray  # (B,) int32 rows used
    n_nodes: np.ndarray  # (B,) int32
    node_kind: np.ndarray  # (B, N) int32 SENSOR / HIDDEN / ACTUATOR
    node_ref: np.ndarray  # (B, N) int32 reading index (sensor) or voxel index (actuator)
    n_edges: np.ndarray  # (B,) int32
    edge_src: np.ndarray  # (B, E) int32 node index
    edge_dst: np.ndarray  # (B, E) int32 node index
    edge_weight: np.ndarray  # (B, E)
    edge_bias: np.ndarray  # (B, E)


class ControlIO(NamedTuple):
    """What one robot's controller reads and writes at a control step: views of its episode's
    arrays (V voxels, R readings, N graph nodes)."""

    n_voxels: int
    voxel_x: np.ndarray  # (V,) grid column of each voxel
    readings: np.ndarray  # (R,) this step's sensor readings
    h_prev: np.ndarray  # (N,) the graph's two state buffers, which take turns
    h_next: np.ndarray  # (N,)
    actuation: np.ndarray  # (V,) written: the actuation of this step


class ControllerType(NamedTuple):
    """One type of controller (a row of :data:`CONTROLLER_TYPES`)."""

    name: str
    spec: type
    """Its specification class: a batch's controller of this type is an instance."""
    shown: str
    """How an error message names it among the types a batch accepts."""
    pack: Callable[[list, Sequence[int]], dict]
    """(specs, n_voxels) -> its fields of :class:`Controllers`, each with a row per robot:
    ``specs[b]`` is robot b's specification when of this type, else None; ``n_voxels[b]`` its
    body's voxels. Raises for a specification that does not fit its body."""


def _pack_zero(specs: list, n_voxels: Sequence[int]) -> dict:
    return {}


def _pack_sine(specs: list, n_voxels: Sequence[int]) -> dict:
    sine = np.zeros((len(specs), 3))
    for b, spec in enumerate(specs):
        if spec is not None:
            sine[b] = (spec.freq, spec.amp, spec.phase)
    return {"sine": sine}


def _pack_table(specs: list, n_voxels: Sequence[int]) -> dict:
    tables = []
    for b, (spec, voxels) in enumerate(zip(specs, n_voxels)):
        if spec is not None and spec.rows.shape[1] != voxels:
            raise bad(f"controllers[{b}]", f"a table of {spec.rows.shape[1]} columns",
                      f"its body has {voxels} voxels")
        tables.append(np.zeros((0, 0)) if spec is None else spec.rows)
    longest = max(1, max(t.shape[0] for t in tables))
    width = max(1, max(t.shape[1] for t in tables))
    table = np.zeros((len(tables), longest, width))
    for b, t in enumerate(tables):
        table[b, : t.shape[0], : t.shape[1]] = t
    period = np.array([max(1, t.shape[0]) for t in tables], dtype=np.int32)
    return {"table": table, "table_period": period}


def _pack_graph(specs: list, n_voxels: Sequence[int]) -> dict:
    empty_i = np.zeros(0, dtype=np.int32)
    empty_f = np.zeros(0)

    def column(name, empty, dtype):
        return pad([getattr(g, name) if g is not None else empty for g in specs], (), dtype)

    def count(name):
        return np.array([getattr(g, name) if g is not None else 0 for g in specs],
                        dtype=np.int32)

    return {
        "n_nodes": count("n_nodes"),
        "node_kind": column("node_kind", empty_i, np.int32),
        "node_ref": column("node_ref", empty_i, np.int32),
        "n_edges": count("n_edges"),
        "edge_src": column("src", empty_i, np.int32),
        "edge_dst": column("dst", empty_i, np.int32),
        "edge_weight": column("weight", empty_f, np.float64),
        "edge_bias": column("bias", empty_f, np.float64),
    }


CONTROLLER_TYPES = (
    ControllerType("zero", Zero, "Zero()", _pack_zero),
    ControllerType("sine", Sine, "Sine(...)", _pack_sine),
    ControllerType("table", Table, "Table(...)", _pack_table),
    ControllerType("graph", GraphArrays, "a compiled Genome", _pack_graph),
)
"""Every controller type; a type's position here is its code."""

Controller = functools.reduce(operator.or_, (entry.spec for entry in CONTROLLER_TYPES))
"""A controller specification of any type of :data:`CONTROLLER_TYPES` (their union)."""

TYPE_CODE = {entry.name: code for code, entry in enumerate(CONTROLLER_TYPES)}
"""Type name -> code."""

ZERO, SINE, TABLE, GRAPH = (TYPE_CODE[name] for name in ("zero", "sine", "table", "graph"))


def type_code(field: str, spec) -> int:
    """The code of ``spec``'s type in :data:`CONTROLLER_TYPES`; an error naming ``field``
    for anything else."""
    for code, entry in enumerate(CONTROLLER_TYPES):
        if isinstance(spec, entry.spec):
            return code
    accepted = ", ".join(entry.shown for entry in CONTROLLER_TYPES)
    raise bad_type(field, spec, f"a controller ({accepted}) or a Genome")


def _text_fields(spec: type) -> tuple | None:
    """The fields of a specification class as the command line gives them (every field a number
    with a default), or None when it cannot be written as text (a table, a graph)."""
    fields = dataclasses.fields(spec)
    if all(type(f.default) in (int, float) for f in fields):
        return fields
    return None


WRITTEN = {entry.name: _text_fields(entry.spec) for entry in CONTROLLER_TYPES
           if _text_fields(entry.spec) is not None}
"""Type name -> its fields, for the types that ``--controller`` can name (text)."""

def _written(name: str, fields: tuple, defaults: bool) -> str:
    if not fields:
        return name
    text = f"{name}:" + ",".join(f"{f.name}={f.name[0].upper()}" for f in fields)
    return text + (" (" + ", ".join(f"{f.default:g}" for f in fields) + ")" if defaults else "")


CONTROLLER_HELP = ", or ".join(_written(name, fields, True) for name, fields in WRITTEN.items())
"""How a controller is written on the command line, e.g. ``zero, or sine:freq=F,amp=A,phase=P
(1, 1, -1)``: every type of :data:`WRITTEN`, with its defaults."""


def parse_controller(text: str):
    """A controller of a type of :data:`WRITTEN` from text: its name, then for a type with
    fields ``:key=value,...`` (any subset; the others keep their defaults)."""
    spec = str(text).strip()
    name, colon, given = spec.partition(":")
    fields = WRITTEN.get(name)
    if fields is None or (colon and not fields):
        written = " or ".join(_written(n, f, False) for n, f in WRITTEN.items())
        raise bad("controller", text, f"use {written}")
    names = [f.name for f in fields]
    options: dict[str, float] = {}
    for item in filter(None, given.split(",")):
        key, _, value = item.partition("=")
        key = key.strip()
        if key not in names:
            raise bad("controller", text, f"unknown {name} parameter {key!r}")
        try:
            options[key] = float(value)
        except ValueError:
            raise bad(f"controller.{key}", value, "must be a number") from None
    return CONTROLLER_TYPES[TYPE_CODE[name]].spec(**options)


def compile_controllers(controllers: Sequence[Controller], n_voxels: Sequence[int]) -> Controllers:
    """Pad a batch of controller specifications into the arrays the kernel reads: robot b's
    is ``controllers[b]``, for a body of ``n_voxels[b]`` voxels."""
    n = len(controllers)
    kind = np.zeros(n, dtype=np.int32)
    of_type: list[list] = [[None] * n for _ in CONTROLLER_TYPES]
    for b, spec in enumerate(controllers):
        kind[b] = code = type_code(f"controllers[{b}]", spec)
        of_type[code][b] = spec
    fields = {"kind": kind}
    for entry, specs in zip(CONTROLLER_TYPES, of_type):
        fields.update(entry.pack(specs, n_voxels))
    return Controllers(**fields)


@uncounted
def control(b, k, t, ctrl, io, params) -> None:
    """Robot ``b``'s controller at control step ``k`` (from 1), time ``t`` [s]: the actuation of
    step k into ``io.actuation`` (:class:`ControlIO`), from ``ctrl`` (:class:`Controllers`).
    ZERO writes nothing: the episode starts with every actuation at 0."""
    kind = ctrl.kind[b]
    if kind == SINE:
        sine_actuation(t, ctrl.sine[b, 0], ctrl.sine[b, 1], ctrl.sine[b, 2], io.n_voxels,
                       io.voxel_x, io.actuation)
    elif kind == TABLE:
        table_actuation(k, ctrl.table[b], ctrl.table_period[b], io.n_voxels, io.actuation)
    elif kind == GRAPH:
        graph = Graph(ctrl.n_nodes[b], ctrl.node_kind[b], ctrl.node_ref[b], ctrl.n_edges[b],
                      ctrl.edge_src[b], ctrl.edge_dst[b], ctrl.edge_weight[b], ctrl.edge_bias[b])
        # The two state buffers take turns: step k reads what step k - 1 wrote.
        old, new = (io.h_prev, io.h_next) if k % 2 == 1 else (io.h_next, io.h_prev)
        graph_step(graph, old, new, io.readings, io.actuation, params.hidden_sigmoid)


__all__ = ["CONTROLLER_HELP", "CONTROLLER_TYPES", "GRAPH", "SINE", "TABLE", "TYPE_CODE", "WRITTEN",
           "ZERO", "ControlIO", "Controller", "ControllerType", "Controllers",
           "compile_controllers", "control", "parse_controller", "type_code"]
