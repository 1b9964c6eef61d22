"""Modules as data: the module record, and cutting a controller along a partition.

A module is a 4-connected set of voxels of a body, the controller nodes located in them and the
edges with both ends inside (docs/decisions.md, "Modules"; paper section 5.2.1). Disassembly
(:func:`cut`) keeps only those edges: every edge whose two ends lie in different modules is
dropped. Putting modules into a body is :mod:`somite.modules.graft`; building a robot from the
modules of donors is :mod:`somite.modules.reassembly`.

Cut ratios (paper section 5.2.2, docs/original-system.md section 6.5; docs/decisions.md, "Cut
ratios"): per module, eta_num is the share of the edges touching the module (at least one end
inside) that cross its boundary (exactly one end inside), and eta_weight the same share of
sum(|w| + |b|). Pooled over donors (the authors' ``CountCuts``), eta_num is all crossing edges of
the donors over all their edges.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from ..brain.genome import Edge, Genome, Node
from ..errors import bad
from ..sim.body import Body, Shape, is_connected, voxel_readings
from ..sim.partition import Partition


def exact_sum(values) -> float:
    """``math.fsum`` (equal sets give bit-equal sums whatever the order), or the plain float
    sum (inf or NaN) when a partial sum overflows, as weights near 1e308 make it."""
    try:
        return math.fsum(values)
    except OverflowError:
        return float(np.sum(np.asarray(values, dtype=np.float64)))

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
        counts = f"voxels={self.size}, nodes={len(self.nodes)}, edges={len(self.edges)}"
        return f"Module({self.label!r}, {counts})"

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
        return voxel_readings(self.sensors[self.voxels.index((node.x, node.y))])[node.slot]


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
            len(self.donor.edges), len(self.crossing), exact_sum(weight), exact_sum(crossing)
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
                exact_sum(weight[touching]),
                exact_sum(weight[crossing]),
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
    """:attr:`~somite.brain.genome.Edge.magnitude` (|w| + |b|) of each edge."""
    return [e.magnitude for e in edges]


def _check_partition(partition: Partition, shape: Shape, field: str) -> None:
    if not isinstance(partition, Partition):
        raise bad(field, type(partition).__name__, "expected a Partition")
    if partition.shape != shape:
        raise bad(
            field, partition.grid_string(),
            f"partition is for shape {partition.shape.grid_string()}, "
            f"the body is {shape.grid_string()}",
        )


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


__all__ = [
    "CutRatio",
    "Disassembly",
    "Module",
    "cut",
    "pooled",
]
