"""The graph controller's synchronous step (docs/decisions.md, "The controller").

At control step k, with h_0 = 0: a sensor node reads h_k = tanh(reading_k); every other node
computes h_k = act(sum over its incoming edges of h_{k-1}(source) * w + b): one step of delay per
edge, the bias summed once per edge, an isolated node giving act(0). Hidden nodes use tanh
(paper) or the sigmoid (original code); actuators use tanh and drive their voxel. A relay node
(only in a controller compiled with length-dependent delays, :mod:`somite.brain.delays`) keeps
its sum as it is: with its one edge of weight 1 and bias 0 it is its source one step later.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._jit import uncounted
from .._math import sigmoid, tanh
from .kinds import HIDDEN, RELAY, SENSOR


class Graph(NamedTuple):
    """One graph controller as :func:`graph_step` reads it (N nodes, E edges; the arrays may be
    longer, padded: only the first ``n_nodes`` and ``n_edges`` are read)."""

    n_nodes: int
    node_kind: np.ndarray  # (N,) int32 SENSOR / HIDDEN / ACTUATOR
    node_ref: np.ndarray  # (N,) int32 reading index (sensor) or voxel index (actuator)
    n_edges: int
    src: np.ndarray  # (E,) int32 node index
    dst: np.ndarray  # (E,) int32 node index
    weight: np.ndarray  # (E,)
    bias: np.ndarray  # (E,)


def graph_of(arrays) -> Graph:
    """The :class:`Graph` of a :class:`~somite.brain.controllers.GraphArrays`."""
    return Graph(arrays.n_nodes, arrays.node_kind, arrays.node_ref, arrays.n_edges, arrays.src,
                 arrays.dst, arrays.weight, arrays.bias)


@uncounted
def graph_step(graph, h_prev, h_next, readings, actuation, hidden_sigmoid):
    """One control step of ``graph`` (:class:`Graph`): ``h_next`` from ``h_prev`` and
    ``readings``; writes ``actuation``."""
    n_nodes = graph.n_nodes
    node_kind = graph.node_kind
    node_ref = graph.node_ref
    n_edges = graph.n_edges
    src = graph.src
    dst = graph.dst
    weight = graph.weight
    bias = graph.bias
    for n in range(n_nodes):
        h_next[n] = 0.0
    for e in range(n_edges):
        h_next[dst[e]] += h_prev[src[e]] * weight[e] + bias[e]
    for n in range(n_nodes):
        kind = node_kind[n]
        if kind == SENSOR:
            h_next[n] = tanh(readings[node_ref[n]])
        elif kind == HIDDEN:
            if hidden_sigmoid:
                h_next[n] = sigmoid(h_next[n])
            else:
                h_next[n] = tanh(h_next[n])
        elif kind == RELAY:
            continue
        else:
            h_next[n] = tanh(h_next[n])
            actuation[node_ref[n]] = h_next[n]
