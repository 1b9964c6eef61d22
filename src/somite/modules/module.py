"""Modules as data: cutting a controller along a partition, and grafting modules into a body.

A module is a 4-connected set of voxels of a body, the controller nodes located in them and the
edges with both ends inside (decisions.md, "Modules"; paper section 5.2.1). Disassembly
(:func:`cut`) keeps only those edges: every edge whose two ends lie in different modules is
dropped. Reassembly (:func:`reassemble`) puts modules, possibly of different donors and shapes,
into a receiver body and adds no edge between modules; :func:`graft` is the one step that both
reassembly and the module library (:mod:`somite.modules.library`) use.

Mapping a module onto a receiver module (decisions.md; original-system.md section 6.3 says the
authors' code is ill-defined for different shapes):

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

Cut ratios (paper section 5.2.2, original-system.md section 6.5): per module, eta_num is the
share of the edges touching the module (at least one end inside) that cross its boundary (exactly
one end inside), and eta_weight the same share of sum(|w| + |b|). Pooled over donors (the
authors' ``CountCuts``), eta_num is all crossing edges of the donors over all their edges.

Transferability (paper eq. 4): rho = v(reassembled) / mean(v(donor 1), v(donor 2)), every v the
mean v_x over the same fixed validation terrains (decisions.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields

import numpy as np

from ..brain.genome import Edge, Genome, Node
from ..errors import bad
from ..sim.body import SENSOR_WIDTH, Body, Shape, is_connected
from .partition import Partition

Voxel = tuple[int, int]


# -- the module record ----------------------------------------------------------------------------


@dataclass(frozen=True, repr=False)
class Module:
    """A connected piece of a robot: voxels with their sensors, nodes and internal edges.

    Coordinates are those of the body the module was cut from (or, for a library module, relative
    to its own bounding-box corner). A module is itself a valid controller for the small robot
    made of its voxels (see :meth:`genome`), which is how it is validated: one node per reading
    and per actuator of its voxels, edges only between its own nodes.

    Attributes
    ----------
    label : str
        The module's name in its partition (``back``, ``torso``, ...).
    voxels : tuple of (x, y)
        Its voxels, 4-connected, bottom row first.
    sensors : tuple of tuple of str
        ``sensors[i]`` are the sensor kinds of ``voxels[i]``, in the donor body's order (the
        order fixes what each sensor slot means).
    nodes : tuple of Node
        The controller nodes located in the voxels.
    edges : tuple of Edge
        The edges with both ends among ``nodes``.
    """

    label: str
    voxels: tuple[Voxel, ...]
    sensors: tuple[tuple[str, ...], ...]
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "voxels", tuple((int(x), int(y)) for x, y in self.voxels))
        object.__setattr__(self, "sensors", tuple(tuple(kinds) for kinds in self.sensors))
        object.__setattr__(self, "nodes", tuple(self.nodes))
        object.__setattr__(self, "edges", tuple(self.edges))
        if not isinstance(self.label, str) or not self.label:
            raise bad("module.label", self.label, "a module needs a non-empty name")
        if len(self.sensors) != len(self.voxels):
            raise bad("module.sensors", len(self.sensors), "need one sensor list per voxel")
        if len(set(self.voxels)) != len(self.voxels):
            raise bad("module.voxels", self.voxels, "a voxel is listed twice")
        # Not a field: derived, and the check of everything else (Genome validates on creation).
        object.__setattr__(self, "_genome", _standalone(self))

    def __repr__(self) -> str:
        return (
            f"Module({self.label!r}, voxels={len(self.voxels)}, nodes={len(self.nodes)}, "
            f"edges={len(self.edges)})"
        )

    @property
    def size(self) -> int:
        """Number of voxels."""
        return len(self.voxels)

    @property
    def origin(self) -> Voxel:
        """Bottom-left corner (min x, min y) of the bounding box."""
        return min(x for x, _ in self.voxels), min(y for _, y in self.voxels)

    def genome(self) -> Genome:
        """The module as the controller of a robot of its own, corner moved to (0, 0)."""
        return self._genome

    def translated(self, dx: int, dy: int) -> Module:
        """The same module moved by (dx, dy) voxels; node ids unchanged."""
        return Module(
            self.label,
            tuple((x + dx, y + dy) for x, y in self.voxels),
            self.sensors,
            tuple(Node(n.id, n.x + dx, n.y + dy, n.kind, n.slot) for n in self.nodes),
            self.edges,
        )

    def relative(self) -> Module:
        """The module moved so that its bounding-box corner is (0, 0)."""
        x0, y0 = self.origin
        return self.translated(-x0, -y0)

    def reading(self, node: Node) -> tuple[str, int]:
        """(sensor kind, component) of a sensor node of this module."""
        return _readings(self.sensors[self.voxels.index((node.x, node.y))])[node.slot]


def _standalone(module: Module) -> Genome:
    """The module's genome on its own body; raises a one-line error if the module is invalid."""
    if not module.voxels:
        raise bad("module.voxels", (), "a module needs at least one voxel")
    if not is_connected(set(module.voxels)):
        raise bad("module.voxels", module.voxels, "a module must be 4-connected")
    shape = Shape.from_cells(module.voxels)
    x0, y0 = module.origin
    kinds = dict(zip(module.voxels, module.sensors))
    # Body() directly, not Body.build: build would sort the kinds and so renumber the slots.
    body = Body(shape, tuple(kinds[(x + x0, y + y0)] for x, y in shape.voxels))
    nodes = tuple(Node(n.id, n.x - x0, n.y - y0, n.kind, n.slot) for n in module.nodes)
    return Genome(body, nodes, module.edges)


def _readings(kinds: Sequence[str]) -> list[tuple[str, int]]:
    """(kind, component) of each reading slot of a voxel with sensors ``kinds``."""
    return [(kind, c) for kind in kinds for c in range(SENSOR_WIDTH[kind])]


# -- disassembly and cut ratios -------------------------------------------------------------------


@dataclass(frozen=True)
class CutRatio:
    """How much of a controller a cut removes: the edges it drops among those it could drop.

    Attributes
    ----------
    n_edges : int
        Edges considered: for a module, those touching it (at least one end inside); for a whole
        controller, all its edges.
    n_cut : int
        Of those, the edges dropped because they cross a module boundary.
    weight, weight_cut : float
        The same two sums of |w| + |b|.
    """

    n_edges: int
    n_cut: int
    weight: float
    weight_cut: float

    @property
    def eta_num(self) -> float:
        """n_cut / n_edges; NaN when there is no edge (nothing to cut is not 'nothing cut')."""
        return self.n_cut / self.n_edges if self.n_edges else math.nan

    @property
    def eta_weight(self) -> float:
        """weight_cut / weight; NaN when the weight is 0."""
        return self.weight_cut / self.weight if self.weight > 0 else math.nan

    def __add__(self, other: CutRatio) -> CutRatio:
        return CutRatio(
            self.n_edges + other.n_edges,
            self.n_cut + other.n_cut,
            self.weight + other.weight,
            self.weight_cut + other.weight_cut,
        )

    def to_dict(self) -> dict:
        """Counts, sums and both etas; NaN written as None (strict JSON)."""
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        data["eta_num"] = _finite_or_none(self.eta_num)
        data["eta_weight"] = _finite_or_none(self.eta_weight)
        return data


@dataclass(frozen=True, repr=False)
class Disassembly:
    """A controller cut along a partition (the result of :func:`cut`).

    Attributes
    ----------
    donor : Genome
        The controller that was cut.
    partition : Partition
        The partition of its body.
    modules : tuple of Module
        One per module of the partition, in ``partition.modules`` order.
    crossing : tuple of Edge
        The dropped edges, whose two ends lie in different modules.
    ratios : tuple of CutRatio
        Per module (same order), the edges touching it and those of them that were cut.
    """

    donor: Genome
    partition: Partition
    modules: tuple[Module, ...]
    crossing: tuple[Edge, ...]
    ratios: tuple[CutRatio, ...]

    def __repr__(self) -> str:
        labels = ", ".join(m.label for m in self.modules)
        return f"Disassembly(modules=[{labels}], crossing={len(self.crossing)})"

    def module(self, label: str) -> Module:
        """The module called ``label``."""
        return self.modules[self._position(label)]

    def ratio(self, label: str) -> CutRatio:
        """The cut ratio of module ``label`` (paper: eta per module)."""
        return self.ratios[self._position(label)]

    @property
    def total(self) -> CutRatio:
        """The whole controller: crossing edges over all edges (the authors' eta, one donor)."""
        weight = _weights(self.donor.edges)
        crossing = _weights(self.crossing)
        return CutRatio(
            len(self.donor.edges), len(self.crossing), math.fsum(weight), math.fsum(crossing)
        )

    def _position(self, label: str) -> int:
        if label not in self.partition.modules:
            raise bad("module", label, f"not a module of the partition {self.partition.modules}")
        return self.partition.modules.index(label)


def cut(genome: Genome, partition: Partition) -> Disassembly:
    """Disassemble ``genome`` into the modules of ``partition``, dropping crossing edges.

    Parameters
    ----------
    genome : Genome
        The donor controller.
    partition : Partition
        A partition of ``genome.body.shape``.

    Returns
    -------
    Disassembly
        The modules (nodes keep their ids and coordinates), the crossing edges and the cut ratio
        of every module.
    """
    _check_partition(partition, genome.body.shape, "partition")
    index = genome.index
    node_module = partition.module_index[index.voxel]  # (N,) module of each node
    src_module = node_module[index.src]  # (E,)
    dst_module = node_module[index.dst]  # (E,)
    weight = np.array(_weights(genome.edges), dtype=np.float64).reshape(-1)
    modules, ratios = [], []
    for k, label in enumerate(partition.modules):
        inside = (src_module == k) & (dst_module == k)
        touching = (src_module == k) | (dst_module == k)
        crossing = touching & ~inside
        voxels = partition.voxels_of(label)
        sensors = tuple(genome.body.sensors[genome.body.shape.index(*v)] for v in voxels)
        nodes = tuple(n for n, m in zip(genome.nodes, node_module.tolist()) if m == k)
        edges = tuple(e for e, keep in zip(genome.edges, inside.tolist()) if keep)
        modules.append(Module(label, voxels, sensors, nodes, edges))
        ratios.append(
            CutRatio(
                int(touching.sum()),
                int(crossing.sum()),
                math.fsum(weight[touching]),
                math.fsum(weight[crossing]),
            )
        )
    dropped = src_module != dst_module
    crossing_edges = tuple(e for e, drop in zip(genome.edges, dropped.tolist()) if drop)
    return Disassembly(genome, partition, tuple(modules), crossing_edges, tuple(ratios))


def pooled(disassemblies: Sequence[Disassembly]) -> CutRatio:
    """The authors' eta: crossing edges of all donors over all their edges (section 6.5).

    A donor that appears twice (the same genome cut along the same partition) counts once.
    """
    seen: list[tuple[Genome, Partition]] = []
    total = CutRatio(0, 0, 0.0, 0.0)
    for item in disassemblies:
        key = (item.donor, item.partition)
        if key in seen:
            continue
        seen.append(key)
        total = total + item.total
    return total


def _weights(edges: Sequence[Edge]) -> list[float]:
    """|w| + |b| of each edge, the paper's measure of an edge's size (eq. 5)."""
    return [abs(e.weight) + abs(e.bias) for e in edges]


def _check_partition(partition: Partition, shape: Shape, field: str) -> None:
    if not isinstance(partition, Partition):
        raise bad(field, type(partition).__name__, "expected a Partition")
    if partition.shape != shape:
        raise bad(
            field, partition.grid_string(),
            f"partition is for shape {partition.shape.grid_string()}, "
            f"the body is {shape.grid_string()}",
        )


# -- grafting modules into a body -----------------------------------------------------------------


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
    slot_of = [
        {reading: s for s, reading in enumerate(_readings(kinds))} for kinds in body.sensors
    ]
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
    for v, kinds in enumerate(body.sensors):
        n_slots = len(_readings(kinds))
        missing.extend(("sensor", v, s) for s in range(n_slots) if ("sensor", v, s) not in placed)
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
    fresh = max(taken, default=-1) + 1
    for key in [k for k in placed if k not in ids] + plain:
        ids[key] = fresh
        fresh += 1
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


# -- reassembly -----------------------------------------------------------------------------------


@dataclass(frozen=True, repr=False)
class Take:
    """One part of a reassembly: module ``label`` of ``donor`` cut along ``partition``."""

    donor: Genome
    partition: Partition
    label: str

    def __repr__(self) -> str:
        return f"Take({self.label!r} of {self.donor!r})"


@dataclass(frozen=True, repr=False)
class Reassembly:
    """A reassembled controller and what the reassembly cost (the result of :func:`reassemble`).

    Attributes
    ----------
    genome : Genome
        The reassembled controller, valid for the receiver body.
    partition : Partition
        The receiver's partition.
    takes : tuple of Take
        Where each receiver module came from, in ``partition.modules`` order.
    grafts : tuple of GraftReport
        What each receiver module kept, dropped and added, same order.
    ratios : tuple of CutRatio
        The cut ratio (eta) of each donor module in its donor, same order.
    pooled : CutRatio
        The authors' eta over the distinct donors.
    """

    genome: Genome
    partition: Partition
    takes: tuple[Take, ...]
    grafts: tuple[GraftReport, ...]
    ratios: tuple[CutRatio, ...]
    pooled: CutRatio

    def __repr__(self) -> str:
        return f"Reassembly({self.genome!r}, modules={self.partition.modules})"

    @property
    def homogeneous(self) -> bool:
        """Whether every donor has the receiver's shape."""
        return all(t.donor.body.shape == self.partition.shape for t in self.takes)


def reassemble(
    receiver_body: Body,
    receiver_partition: Partition,
    parts: Mapping[str, Take | tuple[Genome, Partition, str]],
) -> Reassembly:
    """Build a controller for ``receiver_body`` from modules of donor controllers.

    Parameters
    ----------
    receiver_body : Body
        The body of the new robot (for a homogeneous reassembly, the donors' body).
    receiver_partition : Partition
        A partition of the receiver's shape.
    parts : mapping
        Every module label of ``receiver_partition`` -> a :class:`Take` (or the tuple
        ``(donor genome, donor partition, donor module label)``).

    Returns
    -------
    Reassembly
        The genome, and per module the cut ratio of its donor module and the graft counts.

    Examples
    --------
    The paper's homogeneous worm, back from donor 1 and front from donor 2::

        halves = Partition.preset("worm-halves", "worm")
        reassemble(d1.body, halves, {"back": (d1, halves, "back"), "front": (d2, halves, "front")})
    """
    _check_partition(receiver_partition, receiver_body.shape, "receiver_partition")
    takes = _takes(receiver_partition, parts)
    cuts: dict[int, Disassembly] = {}
    steps = []
    for label, take in zip(receiver_partition.modules, takes):
        # One cut per donor object: a donor giving two modules is cut once.
        key = id(take.donor), id(take.partition)
        if key not in cuts:
            cuts[key] = cut(take.donor, take.partition)
        module = cuts[key].module(take.label)
        target = receiver_partition.voxels_of(label)
        offset = _corner_offset(module.voxels, target)
        steps.append(Graft(label, module, offset, target))
    genome, reports = graft(receiver_body, steps)
    ratios = tuple(cuts[id(t.donor), id(t.partition)].ratio(t.label) for t in takes)
    return Reassembly(
        genome, receiver_partition, takes, reports, ratios, pooled(list(cuts.values()))
    )


def _takes(partition: Partition, parts: Mapping) -> tuple[Take, ...]:
    """Check that ``parts`` gives exactly one donor module per receiver module."""
    if not isinstance(parts, Mapping):
        raise bad("parts", type(parts).__name__, "expected a mapping receiver module -> Take")
    for label in parts:
        if label not in partition.modules:
            raise bad("parts", label, f"not a receiver module; modules are {partition.modules}")
    takes = []
    for label in partition.modules:
        if label not in parts:
            raise bad("parts", label, "receiver module has no donor module")
        part = parts[label]
        if not isinstance(part, Take):
            try:
                part = Take(*part)
            except TypeError:
                raise bad(f"parts[{label}]", part, "expected (donor, partition, label)") from None
        if not isinstance(part.donor, Genome):
            raise bad(f"parts[{label}].donor", type(part.donor).__name__, "expected a Genome")
        _check_partition(part.partition, part.donor.body.shape, f"parts[{label}].partition")
        if part.label not in part.partition.modules:
            raise bad(
                f"parts[{label}].label", part.label,
                f"not a donor module; modules are {part.partition.modules}",
            )
        takes.append(part)
    return tuple(takes)


def _corner_offset(donor: Sequence[Voxel], receiver: Sequence[Voxel]) -> Voxel:
    """Translation that puts the donor's bounding-box corner on the receiver's (decisions.md)."""
    return (
        min(x for x, _ in receiver) - min(x for x, _ in donor),
        min(y for _, y in receiver) - min(y for _, y in donor),
    )


# -- transferability ------------------------------------------------------------------------------


def rho(v_reassembled: float, v_donor1: float, v_donor2: float) -> float:
    """Transferability, paper eq. 4: v_reassembled / ((v_donor1 + v_donor2) / 2).

    NaN when the donors' mean velocity is 0 (or any velocity is NaN).
    """
    mean = (v_donor1 + v_donor2) / 2
    if mean == 0 or not math.isfinite(mean):
        return math.nan
    return v_reassembled / mean


@dataclass(frozen=True)
class Transferability:
    """rho and the velocities behind it, each the mean v_x [m/s] over the same terrains.

    Attributes
    ----------
    terrains : tuple of str
        Names of the validation terrains.
    v_reassembled, v_donor1, v_donor2 : tuple of float
        v_x on each terrain (NaN for an episode that went non-finite).
    """

    terrains: tuple[str, ...]
    v_reassembled: tuple[float, ...]
    v_donor1: tuple[float, ...]
    v_donor2: tuple[float, ...]

    @property
    def means(self) -> tuple[float, float, float]:
        """Mean v_x of the reassembled robot, donor 1 and donor 2."""
        return tuple(
            float(np.mean(v)) if v else math.nan
            for v in (self.v_reassembled, self.v_donor1, self.v_donor2)
        )

    @property
    def rho(self) -> float:
        return rho(*self.means)

    def to_dict(self) -> dict:
        mean_r, mean_1, mean_2 = self.means
        return {
            "terrains": list(self.terrains),
            "v_reassembled": _finite_or_none(mean_r),
            "v_donor1": _finite_or_none(mean_1),
            "v_donor2": _finite_or_none(mean_2),
            "rho": _finite_or_none(self.rho),
            "per_terrain": {
                "reassembled": [_finite_or_none(v) for v in self.v_reassembled],
                "donor1": [_finite_or_none(v) for v in self.v_donor1],
                "donor2": [_finite_or_none(v) for v in self.v_donor2],
            },
        }


def transferability(
    reassembled: Genome,
    donor1: Genome,
    donor2: Genome,
    terrains=None,
    config=None,
    seed: int = 0,
) -> Transferability:
    """Measure the three robots on the same terrains (default: the 10 validation terrains).

    ``config`` is a :class:`~somite.sim.config.SimConfig` (default: the paper's 30 s episodes).
    """
    # Imported here: modules/ is pure data and should not load the simulator to be imported.
    from ..tasks.validation import evaluate, validation_terrains

    terrains = validation_terrains() if terrains is None else list(terrains)
    velocity = evaluate([reassembled, donor1, donor2], terrains, config, seed)  # (3, T)
    rows = [tuple(float(v) for v in row) for row in velocity]
    return Transferability(tuple(t.name for t in terrains), *rows)


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


__all__ = [
    "CutRatio",
    "Disassembly",
    "Graft",
    "GraftReport",
    "Module",
    "Reassembly",
    "Take",
    "Transferability",
    "cut",
    "graft",
    "pooled",
    "reassemble",
    "rho",
    "transferability",
]
