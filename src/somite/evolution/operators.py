"""Initialisation and mutation of graph genomes.

The authors' versions are in docs/original-system.md sections 4.3, 5.3 and 6.2; where somite
differs, docs/decisions.md, "The evolutionary algorithm".

Every operator takes a genome and a ``numpy.random.Generator`` and returns a new genome; one
that cannot act (no edge, no hidden node, no candidate pair) returns an unchanged copy, as the
authors' operators always return a copy.

- ``mutate_edge``: one uniformly chosen edge gets N(0, sigma^2) added to its weight and its bias.
- ``add_edge``: one ordered pair u -> v with u not an actuator, v not a sensor, u != v and no
  edge u -> v yet, chosen with probability proportional to its modularity weight (times
  exp(-distance_bias * d(u, v)) with the distance bias of issue 72); w, b ~ U(-1, 1).
- ``remove_edge``: one uniformly chosen edge goes, then isolated hidden nodes are pruned.
- ``add_node``: one ordered pair (u, v), u not an actuator, v not a sensor, u = v and already
  connected pairs allowed, chosen like ``add_edge``; a new hidden node w gets edges u -> w and
  w -> v (w1, b1, w2, b2 ~ U(-1, 1)); the edge u -> v, if any, stays.
- ``remove_node``: one uniformly chosen hidden node goes with its edges, then pruning.

Modularity bias (section 6.2): with a partition, a pair whose two nodes lie in the same module
weighs omega, any other pair 1. Without a partition, or with omega = 1, there is no bias at all:
pairs are chosen uniformly and ``add_node`` places the new node as without a partition.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numpy as np

from ..brain.delays import node_distances
from ..brain.genome import Edge, Genome, Node, body_table, next_id
from ..brain.kinds import ACTUATOR, HIDDEN, SENSOR
from ..errors import bad
from ..limits import MAX_OMEGA, MAX_OPERATOR_WEIGHT, MAX_SIGMA, at_most
from ..sim.body import Body
from ..sim.partition import Partition


@dataclass(frozen=True)
class Operator:
    """One operator of the roulette: its default weight (the paper's, section 5.3) and how
    :func:`mutate` calls it, ``apply(genome, rng, config, partition) -> child``."""

    default: float
    apply: Callable


OPERATORS: dict[str, Operator] = {
    "mutate_edge": Operator(0.5, lambda g, rng, c, p: mutate_edge(g, rng, c.sigma)),
    "add_edge": Operator(0.1, lambda g, rng, c, p: add_edge(g, rng, p, c.omega,
                                                            c.distance_bias)),
    "remove_edge": Operator(0.1, lambda g, rng, c, p: remove_edge(g, rng)),
    "add_node": Operator(0.15, lambda g, rng, c, p: add_node(g, rng, p, c.omega,
                                                             c.node_placement)),
    "remove_node": Operator(0.15, lambda g, rng, c, p: remove_node(g, rng)),
}
"""The operators, in roulette order: each gets its ``p_<name>`` field of
:class:`OperatorConfig` from here, so a new one is one entry (and its function)."""

OPERATOR_NAMES = tuple(OPERATORS)
WEIGHT_MUTATION = "mutate_edge"
"""The one operator the weights-only ablation keeps (:meth:`OperatorConfig.weights_only`)."""
NODE_PLACEMENTS = ("module", "uniform")
BEYOND_PAPER = ("distance_bias",)
"""Options the paper does not have, left out of :meth:`OperatorConfig.to_dict` at 0 (off)."""
MAX_DISTANCE_BIAS = 10.0
"""The largest ``distance_bias`` [1/voxel]: a pair 10 voxels apart then still weighs
exp(-100), far above the smallest float, so the weights never all vanish."""


def _with_operator_weights(cls):
    """Give ``cls`` a float field ``p_<name>`` per operator of :data:`OPERATORS`, with its
    default, before the fields it declares itself."""
    own = cls.__dict__.get("__annotations__", {})
    cls.__annotations__ = {**{f"p_{name}": "float" for name in OPERATORS}, **own}
    for name, operator in OPERATORS.items():
        setattr(cls, f"p_{name}", operator.default)
    return cls


@dataclass(frozen=True)
@_with_operator_weights
class OperatorConfig:
    """Operator probabilities and parameters (defaults: the paper's, section 5.3).

    Probabilities are relative weights of a roulette, so they need not sum to 1; the
    weights-only ablation is :meth:`weights_only`.

    Attributes
    ----------
    p_mutate_edge, p_add_edge, p_remove_edge, p_add_node, p_remove_node : float
        Roulette weights of the operators, one ``p_<name>`` per entry of :data:`OPERATORS`.
    sigma : float
        Standard deviation of the Gaussian added to a weight and a bias by ``mutate_edge``.
    omega : float
        Weight of same-module pairs in ``add_edge`` and ``add_node`` (other pairs weigh 1);
        used only when a partition is given.
    node_placement : str
        ``module`` (paper): with omega != 1, a node added between two nodes of one module goes
        to a random voxel of that module; ``uniform`` (authors' code), or omega = 1: to a random
        voxel of the body.
    distance_bias : float
        Beyond the paper (issue 72): ``add_edge`` weighs a pair u -> v by
        exp(-distance_bias * d), d the distance between their voxels in voxels (0 inside one
        voxel), on top of omega; 0 (default): no bias. ``add_node`` is unchanged.
    """

    sigma: float = 0.7
    omega: float = 1.0
    node_placement: str = "module"
    distance_bias: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "node_placement":
                if value not in NODE_PLACEMENTS:
                    raise bad(f.name, value, f"use one of {NODE_PLACEMENTS}")
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise bad(f.name, value, "must be a number")
            if not math.isfinite(value):
                raise bad(f.name, value, "must be finite")
            if f.name.startswith("p_") and not 0 <= value <= MAX_OPERATOR_WEIGHT:
                # Relative weights; bounded so that their sum stays a number.
                raise bad(f.name, value,
                          f"probabilities must be in [0, {MAX_OPERATOR_WEIGHT:g}]")
        if sum(self.probabilities) <= 0:
            raise bad("p_mutate_edge", self.p_mutate_edge, "at least one probability must be > 0")
        if self.sigma < 0:
            raise bad("sigma", self.sigma, "must be >= 0")
        at_most("sigma", self.sigma, MAX_SIGMA)
        if self.omega <= 0:
            raise bad("omega", self.omega, "must be > 0")
        # Beyond it the operators' weight sums overflow to inf and the draws go wrong.
        at_most("omega", self.omega, MAX_OMEGA)
        if not 0 <= self.distance_bias <= MAX_DISTANCE_BIAS:
            raise bad("distance_bias", self.distance_bias,
                      f"must be in [0, {MAX_DISTANCE_BIAS:g}] (per voxel; 0: no bias)")

    @property
    def probabilities(self) -> tuple[float, ...]:
        """The operator weights, in the order of :data:`OPERATOR_NAMES`."""
        return tuple(float(getattr(self, f"p_{name}")) for name in OPERATOR_NAMES)

    def weights_only(self) -> OperatorConfig:
        """These options with weight mutation alone on: weight 1 for :data:`WEIGHT_MUTATION`,
        0 for every other operator of :data:`OPERATORS`."""
        return replace(self, **{f"p_{name}": float(name == WEIGHT_MUTATION)
                                for name in OPERATORS})

    def to_dict(self) -> dict:
        """The options as a JSON-ready dict; ``distance_bias`` only when set, so that every
        other run keeps the ``config.json`` and fingerprint it always had."""
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name not in BEYOND_PAPER or getattr(self, f.name) != 0.0}

    @classmethod
    def from_dict(cls, data: dict) -> OperatorConfig:
        """Inverse of :meth:`to_dict`; missing options take their defaults."""
        known = {f.name for f in fields(cls)}
        for key in data:
            if key not in known:
                raise bad(key, data[key], f"unknown operator option; use {sorted(known)}")
        return cls(**data)


DEFAULT_CONFIG = OperatorConfig()


# -- initialisation -----------------------------------------------------------------------------


def initial_genome(body: Body, rng: np.random.Generator, delay_per_voxel: float = 0.0) -> Genome:
    """The minimal controller of ``body`` (section 4.3), with edges delayed by
    ``delay_per_voxel`` (:mod:`somite.brain.delays`; 0: the paper's one step).

    Every sensor and actuator node, no hidden node, and an edge from each sensor to the actuator
    of its own voxel with w, b ~ U(-1, 1). Ids follow the authors' order: voxel by voxel (bottom
    row first), each voxel's sensor slots then its actuator. Weight and bias are drawn in that
    order, edge by edge.
    """
    table = body_table(body)
    params = rng.uniform(-1.0, 1.0, size=(sum(table.n_slots), 2))
    nodes: list[Node] = []
    edges: list[Edge] = []
    for (x, y), n_slots in zip(body.shape.voxels, table.n_slots):
        first = len(nodes)
        actuator = first + n_slots
        nodes.extend(Node(first + s, x, y, "sensor", s) for s in range(n_slots))
        nodes.append(Node(actuator, x, y, "actuator"))
        for s in range(n_slots):
            w, b = params[len(edges)]
            edges.append(Edge(first + s, actuator, float(w), float(b)))
    return Genome(body, tuple(nodes), tuple(edges), delay_per_voxel)


# -- operators ----------------------------------------------------------------------------------


def mutate_edge(genome: Genome, rng: np.random.Generator, sigma: float = 0.7) -> Genome:
    """Add N(0, sigma^2) to the weight and the bias of one uniformly chosen edge."""
    if not (sigma >= 0 and math.isfinite(sigma)):
        raise bad("sigma", sigma, "must be a finite number >= 0")
    if not genome.edges:
        return copy.copy(genome)
    k = int(rng.integers(len(genome.edges)))
    dw, db = rng.normal(0.0, sigma, size=2)
    old = genome.edges[k]
    new = Edge(old.src, old.dst, float(old.weight + dw), float(old.bias + db))
    return replace(genome, edges=genome.edges[:k] + (new,) + genome.edges[k + 1 :])


def add_edge(
    genome: Genome,
    rng: np.random.Generator,
    partition: Partition | None = None,
    omega: float = 1.0,
    distance_bias: float = 0.0,
) -> Genome:
    """Add an edge u -> v with w, b ~ U(-1, 1) between a new valid pair, modularity-weighted
    and, with ``distance_bias`` > 0, weighted by exp(-distance_bias * d(u, v)) too."""
    index = genome.index
    mask = _pair_mask(index.kind)
    mask[index.src, index.dst] = False
    np.fill_diagonal(mask, False)
    pick = _pick_pair(mask, _node_modules(genome, partition, omega), omega, rng,
                      _distance_weights(genome, distance_bias))
    if pick is None:
        return copy.copy(genome)
    u, v = pick
    w, b = rng.uniform(-1.0, 1.0, size=2)
    edge = Edge(int(index.ids[u]), int(index.ids[v]), float(w), float(b))
    return replace(genome, edges=genome.edges + (edge,))


def remove_edge(genome: Genome, rng: np.random.Generator) -> Genome:
    """Remove one uniformly chosen edge, then prune isolated hidden nodes."""
    if not genome.edges:
        return copy.copy(genome)
    keep = np.ones(len(genome.edges), dtype=bool)
    keep[int(rng.integers(len(genome.edges)))] = False
    return _rebuild(genome, np.ones(len(genome.nodes), dtype=bool), keep)


def add_node(
    genome: Genome,
    rng: np.random.Generator,
    partition: Partition | None = None,
    omega: float = 1.0,
    node_placement: str = "module",
) -> Genome:
    """Add a hidden node w and edges u -> w -> v for a modularity-weighted pair (u, v).

    ``node_placement="module"`` puts w in a uniformly random voxel of the module of u and v when
    a partition is given, omega != 1 and they share a module, otherwise in a uniformly random
    voxel of the body; ``"uniform"`` always does the latter.
    """
    if node_placement not in NODE_PLACEMENTS:
        raise bad("node_placement", node_placement, f"use one of {NODE_PLACEMENTS}")
    index = genome.index
    modules = _node_modules(genome, partition, omega)
    pick = _pick_pair(_pair_mask(index.kind), modules, omega, rng)
    if pick is None:
        return copy.copy(genome)
    u, v = pick
    if node_placement == "module" and modules is not None and modules[u] == modules[v]:
        candidates = np.flatnonzero(partition.module_index == modules[u])
    else:
        candidates = np.arange(genome.body.shape.n_voxels)
    x, y = genome.body.shape.voxels[int(candidates[rng.integers(len(candidates))])]
    w1, b1, w2, b2 = rng.uniform(-1.0, 1.0, size=4)
    hidden = next_id(genome)
    new_edges = (
        Edge(int(index.ids[u]), hidden, float(w1), float(b1)),
        Edge(hidden, int(index.ids[v]), float(w2), float(b2)),
    )
    node = Node(hidden, x, y, "hidden")
    return replace(genome, nodes=genome.nodes + (node,), edges=genome.edges + new_edges)


def remove_node(genome: Genome, rng: np.random.Generator) -> Genome:
    """Remove one uniformly chosen hidden node and its edges, then prune isolated hidden nodes."""
    index = genome.index
    hidden = np.flatnonzero(index.kind == HIDDEN)
    if hidden.size == 0:
        return copy.copy(genome)
    gone = int(hidden[rng.integers(hidden.size)])
    keep_nodes = np.ones(len(genome.nodes), dtype=bool)
    keep_nodes[gone] = False
    keep_edges = (index.src != gone) & (index.dst != gone)
    return _rebuild(genome, keep_nodes, keep_edges)


def prune(genome: Genome) -> Genome:
    """Remove the hidden nodes that have neither incoming nor outgoing edges."""
    return _rebuild(
        genome, np.ones(len(genome.nodes), dtype=bool), np.ones(len(genome.edges), dtype=bool)
    )


# -- the roulette -------------------------------------------------------------------------------


def mutate(
    genome: Genome,
    rng: np.random.Generator,
    config: OperatorConfig | None = None,
    partition: Partition | None = None,
) -> tuple[Genome, str]:
    """Pick an operator by roulette over ``config``'s probabilities and apply it.

    Returns
    -------
    (Genome, str)
        The child and the name of the operator applied (one of :data:`OPERATOR_NAMES`).
    """
    config = config or DEFAULT_CONFIG
    weights = config.probabilities
    spin = rng.random() * sum(weights)
    for name, weight in zip(OPERATOR_NAMES, weights):  # noqa: B007 - name is used after
        # A zero weight never wins: spin < 0 is false.
        if spin < weight:
            break
        spin -= weight
    else:
        # Rounding ran the spin past the end: the last operator that can win takes it.
        name = next(n for n, w in zip(reversed(OPERATOR_NAMES), reversed(weights)) if w > 0)
    return OPERATORS[name].apply(genome, rng, config, partition), name


# -- helpers ------------------------------------------------------------------------------------


def _pair_mask(kind: np.ndarray) -> np.ndarray:
    """(N, N) bool: u -> v allowed by kinds alone (u not an actuator, v not a sensor)."""
    return (kind != ACTUATOR)[:, None] & (kind != SENSOR)[None, :]


def _node_modules(
    genome: Genome, partition: Partition | None, omega: float
) -> np.ndarray | None:
    """(N,) module of each node's voxel; None without a partition or with omega = 1, which
    is neutral (no bias in the pair and none in the placement of a new node)."""
    if partition is None:
        return None
    if partition.shape != genome.body.shape:
        raise bad(
            "partition", partition.grid_string(),
            f"partition is for shape {partition.shape.grid_string()}, "
            f"the genome's body is {genome.body.shape.grid_string()}",
        )
    return None if omega == 1.0 else partition.module_index[genome.index.voxel]


def _pick_pair(mask, modules, omega: float, rng: np.random.Generator,
               distance=None) -> tuple[int, int] | None:
    """Draw one True cell (u, v) of ``mask``; same-module cells weigh ``omega``, others 1,
    times ``distance[u, v]`` when given (:func:`_distance_weights`)."""
    if not (omega > 0 and math.isfinite(omega)):
        raise bad("omega", omega, "must be a finite number > 0")
    flat = np.flatnonzero(mask)
    if flat.size == 0:
        return None
    if modules is None and distance is None:
        # The paper's uniform draw, one integer: kept as it was, so unbiased runs draw the
        # same numbers as before the distance bias existed.
        k = flat[rng.integers(flat.size)]
    else:
        weight = np.ones(flat.size)
        if modules is not None:
            same = (modules[:, None] == modules[None, :]).ravel()[flat]
            weight = np.where(same, omega, 1.0)
        if distance is not None:
            weight = weight * distance.ravel()[flat]
        cumulative = np.cumsum(weight)
        at = np.searchsorted(cumulative, rng.random() * cumulative[-1], side="right")
        k = flat[min(int(at), flat.size - 1)]
    return divmod(int(k), mask.shape[1])


def _distance_weights(genome: Genome, distance_bias: float) -> np.ndarray | None:
    """(N, N) exp(-distance_bias * d(u, v)), d the distance between the voxels of nodes u and v
    in voxels (:func:`~somite.brain.delays.node_distances`); None for 0, no bias."""
    if distance_bias == 0.0:
        return None
    if not (0.0 < distance_bias <= MAX_DISTANCE_BIAS):
        raise bad("distance_bias", distance_bias, f"must be in [0, {MAX_DISTANCE_BIAS:g}]")
    xy = body_table(genome.body).voxel_xy[genome.index.voxel]
    return np.exp(-distance_bias * node_distances(xy))


def _rebuild(genome: Genome, keep_nodes: np.ndarray, keep_edges: np.ndarray) -> Genome:
    """The genome restricted to the kept nodes and edges, minus hidden nodes left isolated."""
    index = genome.index
    touched = np.zeros(len(genome.nodes), dtype=bool)
    touched[index.src[keep_edges]] = True
    touched[index.dst[keep_edges]] = True
    keep_nodes = keep_nodes & ((index.kind != HIDDEN) | touched)
    nodes = tuple(n for n, k in zip(genome.nodes, keep_nodes.tolist()) if k)
    edges = tuple(e for e, k in zip(genome.edges, keep_edges.tolist()) if k)
    return replace(genome, nodes=nodes, edges=edges)
