"""Edge lengths, and delays that grow with them (issue 72; docs/decisions.md, "Edge length").

The paper's controller delays every edge by one control step, however far apart its two nodes
sit. With ``delay_per_voxel`` = s > 0 (a genome's, :class:`~somite.brain.genome.Genome`), an
edge of length d voxels is delayed by

    delay = min(MAX_EDGE_DELAY, max(1, ceil(s * d)))

control steps, where d is the Euclidean distance between the centres of the voxels of the
edge's two nodes, in voxel sides (0 for two nodes of one voxel, 1 for neighbours, sqrt(2) for
diagonal neighbours). s = 1 is one step per voxel crossed; s = 0 is the paper's one step for
every edge. ``ceil`` forgives 1e-9 of rounding, so that 0.7 x 10 voxels is 7 steps, not 8.

The kernel runs an edge of delay D as the paper's edge after a chain of D - 1 relay nodes
(:data:`~somite.brain.kinds.RELAY`), each passing its source's value on one step later, exactly
(x * 1 + 0 is x). The compiled controller grows by those nodes and edges; the node buffers,
the kernels and every backend stay as they are, and a controller without delays compiles to
exactly the arrays it did before (:func:`with_relays` is not called).
"""

from __future__ import annotations

import numpy as np

from .. import checks
from .kinds import KIND_DTYPE, RELAY

MAX_EDGE_DELAY = 60
"""The longest delay of an edge, in control steps (1 s at 60 Hz): longer ones are cut to it, so
that a controller holds at most 59 relays per edge."""

MAX_DELAY_PER_VOXEL = 10.0
"""The largest ``delay_per_voxel``: 10 steps per voxel reach :data:`MAX_EDGE_DELAY` at 6 voxels."""

_ROUNDING = 1e-9


def check_delay_per_voxel(field: str, value) -> float:
    """``value`` as a float in [0, :data:`MAX_DELAY_PER_VOXEL`], else a one-line error."""
    return float(checks.real(field, value, 0.0, MAX_DELAY_PER_VOXEL))


def node_distances(voxel_xy: np.ndarray) -> np.ndarray:
    """(N, N) distances [voxels] between the voxels (N, 2) of N nodes."""
    xy = np.asarray(voxel_xy, dtype=np.float64)
    dx = xy[:, None, 0] - xy[None, :, 0]
    dy = xy[:, None, 1] - xy[None, :, 1]
    return np.sqrt(dx * dx + dy * dy)


def edge_lengths(genome) -> np.ndarray:
    """(E,) length of each edge of ``genome`` [voxels], in its edges' order."""
    index = genome.index
    xy = np.array(genome.body.shape.voxels, dtype=np.float64).reshape(-1, 2)[index.voxel]
    d = xy[index.src] - xy[index.dst]
    return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])


def delays(lengths: np.ndarray, per_voxel: float) -> np.ndarray:
    """(E,) int64 delay [control steps] of edges of ``lengths`` [voxels] (the module's law)."""
    if per_voxel == 0.0:
        return np.ones(len(lengths), dtype=np.int64)
    steps = np.ceil(np.asarray(lengths, dtype=np.float64) * per_voxel - _ROUNDING)
    return np.clip(steps, 1, MAX_EDGE_DELAY).astype(np.int64)


def edge_delays(genome) -> np.ndarray:
    """(E,) delay of each edge of ``genome`` [control steps] under its ``delay_per_voxel``."""
    return delays(edge_lengths(genome), genome.delay_per_voxel)


def with_relays(kind, ref, src, dst, weight, bias, edge_delay):
    """The compiled arrays (``node_kind``, ``node_ref``, ``src``, ``dst``, ``weight``, ``bias``)
    with each edge of delay D > 1 run through D - 1 relay nodes: its own row keeps its place,
    weight and bias, its source becoming the last relay, so that every node sums its edges in
    the genome's order, as without delays; the relays and their edges (weight 1, bias 0) come
    after the genome's nodes and edges."""
    extra = np.asarray(edge_delay, dtype=np.int64) - 1
    n_relays = int(extra.sum())
    if n_relays == 0:
        return kind, ref, src, dst, weight, bias
    n_nodes = len(kind)
    src = src.copy()
    chain_src = np.empty(n_relays, dtype=src.dtype)
    chain_dst = np.empty(n_relays, dtype=dst.dtype)
    at = 0
    for e in np.flatnonzero(extra > 0).tolist():
        relays = n_nodes + at + np.arange(extra[e])
        chain_src[at] = src[e]
        chain_src[at + 1: at + extra[e]] = relays[:-1]
        chain_dst[at: at + extra[e]] = relays
        src[e] = relays[-1]
        at += int(extra[e])
    return (
        np.concatenate([kind, np.full(n_relays, RELAY, dtype=KIND_DTYPE)]).astype(kind.dtype),
        np.concatenate([ref, np.full(n_relays, -1, dtype=ref.dtype)]),
        np.concatenate([src, chain_src]),
        np.concatenate([dst, chain_dst]),
        np.concatenate([weight, np.ones(n_relays)]),
        np.concatenate([bias, np.zeros(n_relays)]),
    )


def length_counts(genomes) -> dict[float, int]:
    """How many edges of ``genomes`` have each length [voxels, to 3 decimals], shortest first:
    the distribution the ``lengths`` comparison reports (docs/results.md)."""
    lengths = np.concatenate([edge_lengths(g) for g in genomes] or [np.zeros(0)])
    values, counts = np.unique(np.round(lengths, 3), return_counts=True)
    return {float(v): int(c) for v, c in zip(values, counts)}


def longest_delay(per_voxel: float, shape) -> int:
    """The longest delay an edge of a body of ``shape`` can get (its farthest two voxels)."""
    xy = np.array(shape.voxels, dtype=np.float64).reshape(-1, 2)
    return int(delays(np.array([node_distances(xy).max(initial=0.0)]), per_voxel)[0])


__all__ = ["MAX_DELAY_PER_VOXEL", "MAX_EDGE_DELAY", "check_delay_per_voxel", "delays",
           "edge_delays", "edge_lengths", "length_counts", "longest_delay", "node_distances",
           "with_relays"]
