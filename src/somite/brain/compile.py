"""Genome -> GraphArrays: the flat form the episode kernel runs.

See docs/decisions.md, "The controller".

A sensor node refers to its reading by position in ``body.readings`` (voxel by voxel, slot by
slot, docs/original-system.md section 3), an actuator node to its voxel's position in
``body.shape.voxels``; edges refer to nodes by position in ``genome.nodes``.
"""

from __future__ import annotations

import numpy as np

from .controllers import GraphArrays
from .delays import edge_delays, with_relays
from .genome import Genome, body_table
from .kinds import ACTUATOR, SENSOR


def compile_genome(genome: Genome) -> GraphArrays:
    """Flatten ``genome`` into :class:`GraphArrays` (N nodes, E edges).

    Parameters
    ----------
    genome : Genome
        A validated genome.

    Returns
    -------
    GraphArrays
        ``node_kind`` (N,) kind codes (:mod:`somite.brain.kinds`); ``node_ref`` (N,) int32:
        reading index for sensors, voxel index for actuators, -1 for hidden nodes; ``src``,
        ``dst`` (E,) int32 node positions; ``weight``, ``bias`` (E,) float64. A genome with
        ``delay_per_voxel`` gets relay nodes and edges after its own (:mod:`.delays`).
    """
    index = genome.index
    table = body_table(genome.body)
    kind = index.kind.copy()
    ref = np.where(
        kind == SENSOR,
        table.first_reading[index.voxel] + index.slot,
        np.where(kind == ACTUATOR, index.voxel, -1),
    ).astype(np.int32)
    n_edges = len(genome.edges)
    weight = np.fromiter((e.weight for e in genome.edges), dtype=np.float64, count=n_edges)
    bias = np.fromiter((e.bias for e in genome.edges), dtype=np.float64, count=n_edges)
    columns = (kind, ref, index.src.astype(np.int32), index.dst.astype(np.int32), weight, bias)
    if genome.delay_per_voxel:
        columns = with_relays(*columns, edge_delays(genome))
    kind, ref, src, dst, weight, bias = columns
    return GraphArrays(
        node_kind=kind,
        node_ref=ref,
        src=src,
        dst=dst,
        weight=weight,
        bias=bias,
        body=genome.body,
    )
