"""The graph controller's synchronous step (docs/decisions.md, "The controller").

At control step k, with h_0 = 0: a sensor node reads h_k = tanh(reading_k); every other node
computes h_k = act(sum over its incoming edges of h_{k-1}(source) * w + b): one step of delay per
edge, the bias summed once per edge, an isolated node giving act(0). Hidden nodes use tanh
(paper) or the sigmoid (original code); actuators use tanh and drive their voxel.
"""

from __future__ import annotations

from .._jit import uncounted
from .._math import sigmoid, tanh
from .kinds import HIDDEN, SENSOR


@uncounted
def graph_step(n_nodes, node_kind, node_ref, n_edges, src, dst, weight, bias,
               h_prev, h_next, readings, actuation, hidden_sigmoid):
    """One control step: ``h_next`` from ``h_prev`` and ``readings``; writes ``actuation``.

    ``node_ref`` is the reading index of a sensor node and the voxel index of an actuator.
    """
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
        else:
            h_next[n] = tanh(h_next[n])
            actuation[node_ref[n]] = h_next[n]
