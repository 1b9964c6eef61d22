"""Grafting: putting modules into the cells of a receiver body, adding no edge between them.

:func:`graft` is the one step that both reassembly (:mod:`somite.modules.reassembly`) and the
module library (:mod:`somite.modules.library`) use.

Mapping a module onto a receiver module (docs/decisions.md, "Reassembly"; docs/original-system.md
section 6.3 says the authors' code is ill-defined for different shapes):

- the bounding boxes of the two modules are aligned at their bottom-left corner, and a receiver
  voxel takes the donor voxel at the same relative position; donor voxels that fall outside the
  receiver module are dropped with their nodes;
- a sensor node maps onto the receiver voxel's reading of the same sensor kind and component
  (a donor lidar ray l2 onto the receiver voxel's lidar ray l2), or is dropped when the receiver
  voxel has no such sensor; an actuator node maps onto the receiver voxel's actuator; a hidden
  node moves with its voxel;
- an edge survives when both its ends survive; hidden nodes left without edges are pruned;
- receiver readings and actuators that received no donor node get a plain node without edges,
  so that the genome stays valid;
- node ids: each node keeps its donor id when no node placed before it took that id (modules in
  the receiver partition's order), otherwise it gets a fresh id above all kept ones; plain nodes
  always get fresh ids. Reassembling a robot from its own modules therefore keeps every id.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

from ..brain.genome import Edge, Genome, Node, fresh_ids
from ..errors import bad
from ..sim.body import Body
from .module import Module, Voxel


@dataclass(frozen=True)
class Graft:
    """One step of building a controller: put ``module`` into some cells of a receiver body.

    Module voxel (x, y) lands on receiver cell (x + dx, y + dy); when that cell is not among
    ``target``, the voxel and its nodes are dropped.

    Attributes
    ----------
    name : str
        What the step is called in reports (the receiver module, or a library placement).
    module : Module
        The module placed.
    offset : (dx, dy)
        Translation from the module's coordinates to the receiver's.
    target : tuple of (x, y)
        The receiver cells this step fills; the cells of different steps are disjoint.
    """

    name: str
    module: Module
    offset: Voxel
    target: tuple[Voxel, ...]


@dataclass(frozen=True)
class GraftReport:
    """What one :class:`Graft` kept, dropped and added (counts of voxels, nodes and edges).

    Attributes
    ----------
    name : str
        The graft's name.
    offset : (dx, dy)
        The graft's translation.
    n_voxels_matched : int
        Module voxels that landed on a target cell.
    n_voxels_dropped : int
        Module voxels with no target cell (dropped with their nodes).
    n_voxels_empty : int
        Target cells that received no module voxel (they get plain nodes).
    n_nodes_kept, n_edges_kept : int
        Module nodes and edges present in the result.
    n_nodes_dropped : int
        Module nodes with no counterpart: in a dropped voxel, or a sensor whose kind and
        component the receiver voxel lacks.
    n_edges_dropped : int
        Module edges lost because an end was dropped.
    n_hidden_pruned : int
        Hidden nodes that kept their voxel but lost every edge.
    n_nodes_added : int
        Plain nodes (no edge) added for target readings and actuators no module node reached.
    """

    name: str
    offset: Voxel
    n_voxels_matched: int
    n_voxels_dropped: int
    n_voxels_empty: int
    n_nodes_kept: int
    n_nodes_dropped: int
    n_edges_kept: int
    n_edges_dropped: int
    n_hidden_pruned: int
    n_nodes_added: int

    def to_dict(self) -> dict:
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        data["offset"] = list(self.offset)
        return data


# A node of the result before it has an id: ("sensor", voxel, slot), ("actuator", voxel) or
# ("hidden", graft position, donor id, (x, y)). Sensor and actuator keys are the receiver's own,
# so each reading and actuator gets exactly one node however many modules reach it.
_Key = tuple


def graft(body: Body, grafts: Sequence[Graft]) -> tuple[Genome, tuple[GraftReport, ...]]:
    """Build a controller for ``body`` from modules; no edge is added between modules.

    Parameters
    ----------
    body : Body
        The receiver body.
    grafts : sequence of Graft
        The modules to place, with disjoint targets made of cells of ``body``.

    Returns
    -------
    (Genome, tuple of GraftReport)
        The controller (nodes sorted by id) and one report per graft, in order.
    """
    _check_targets(body, grafts)
    slot_of = [{reading: s for s, reading in enumerate(slots)} for slots in body.slots]
    voxel_index = {v: i for i, v in enumerate(body.shape.voxels)}
    placed: dict[_Key, tuple[int, Node]] = {}  # key -> (graft position, donor node)
    kept_edges: list[tuple[_Key, _Key, Edge, int]] = []
    counts: list[dict] = [{} for _ in grafts]
    for g, step in enumerate(grafts):
        keys = _map_nodes(step, g, voxel_index, slot_of)
        edges = [(keys[e.src], keys[e.dst], e, g) for e in step.module.edges]
        kept = [item for item in edges if item[0] is not None and item[1] is not None]
        kept_edges.extend(kept)
        for node in step.module.nodes:
            if keys[node.id] is not None:
                placed[keys[node.id]] = (g, node)
        moved = {(x + step.offset[0], y + step.offset[1]) for x, y in step.module.voxels}
        counts[g].update(
            n_voxels_matched=len(moved & set(step.target)),
            n_voxels_dropped=len(moved - set(step.target)),
            n_voxels_empty=len(set(step.target) - moved),
            n_nodes_dropped=sum(k is None for k in keys.values()),
            n_edges_kept=len(kept),
            n_edges_dropped=len(edges) - len(kept),
        )
    used = {key for src, dst, _, _ in kept_edges for key in (src, dst)}
    pruned = [key for key in placed if key[0] == "hidden" and key not in used]
    for key in pruned:
        del placed[key]
    for g in range(len(grafts)):
        counts[g]["n_hidden_pruned"] = sum(key[1] == g for key in pruned)
        counts[g]["n_nodes_kept"] = sum(owner == g for owner, _ in placed.values())
    plain = _plain_keys(body, placed)
    owner_of = {cell: g for g, step in enumerate(grafts) for cell in step.target}
    for g in range(len(grafts)):
        counts[g]["n_nodes_added"] = sum(
            owner_of.get(body.shape.voxels[key[1]]) == g for key in plain
        )
    genome = _assign_ids(body, placed, plain, kept_edges)
    reports = tuple(
        GraftReport(step.name, tuple(step.offset), **c) for step, c in zip(grafts, counts)
    )
    return genome, reports


def _check_targets(body: Body, grafts: Sequence[Graft]) -> None:
    """Targets must be cells of the body, and no cell may be filled twice."""
    owner: dict[Voxel, str] = {}
    for step in grafts:
        if not isinstance(step, Graft) or not isinstance(step.module, Module):
            raise bad("graft", step, "expected a Graft of a Module")
        for cell in step.target:
            body.shape.index(*cell)
            if cell in owner:
                raise bad("graft", step.name, f"voxel {cell} is already filled by {owner[cell]}")
            owner[cell] = step.name


def _map_nodes(step: Graft, g: int, voxel_index: dict, slot_of: list) -> dict[int, _Key | None]:
    """Donor node id -> receiver key, or None when the node has no counterpart."""
    dx, dy = step.offset
    target = set(step.target)
    keys: dict[int, _Key | None] = {}
    for node in step.module.nodes:
        cell = (node.x + dx, node.y + dy)
        if cell not in target:
            keys[node.id] = None
            continue
        v = voxel_index[cell]
        if node.kind == "sensor":
            slot = slot_of[v].get(step.module.reading(node))
            keys[node.id] = None if slot is None else ("sensor", v, slot)
        elif node.kind == "actuator":
            keys[node.id] = ("actuator", v)
        else:
            keys[node.id] = ("hidden", g, node.id, cell)
    return keys


def _plain_keys(body: Body, placed: dict) -> list[_Key]:
    """Receiver readings and actuators that no module node reached, in the body's order."""
    missing = []
    for v, slots in enumerate(body.slots):
        readings = (("sensor", v, s) for s in range(len(slots)))
        missing.extend(key for key in readings if key not in placed)
        if ("actuator", v) not in placed:
            missing.append(("actuator", v))
    return missing


def _assign_ids(body: Body, placed: dict, plain: list, kept_edges: list) -> Genome:
    """Give every key a node id (donor ids kept where free) and build the genome."""
    ids: dict[_Key, int] = {}
    taken: set[int] = set()
    for key, (_, node) in placed.items():
        if node.id not in taken:
            ids[key] = node.id
            taken.add(node.id)
    pending = [k for k in placed if k not in ids] + plain
    for key, new in zip(pending, fresh_ids(taken, len(pending))):
        ids[key] = new
    nodes = [_node(body, key, ids[key]) for key in ids]
    nodes.sort(key=lambda n: n.id)
    edges = tuple(Edge(ids[s], ids[d], e.weight, e.bias) for s, d, e, _ in kept_edges)
    return Genome(body, tuple(nodes), edges)


def _node(body: Body, key: _Key, node_id: int) -> Node:
    if key[0] == "hidden":
        x, y = key[3]
        return Node(node_id, x, y, "hidden")
    x, y = body.shape.voxels[key[1]]
    if key[0] == "sensor":
        return Node(node_id, x, y, "sensor", key[2])
    return Node(node_id, x, y, "actuator")


__all__ = [
    "Graft",
    "GraftReport",
    "graft",
]
