"""The graph controller's step against a plain-Python reference.

See docs/decisions.md, "The controller".
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.bench import random_graph
from somite.brain.controllers import GraphArrays
from somite.brain.kernels import graph_of, graph_step
from somite.brain.kinds import ACTUATOR, HIDDEN, SENSOR
from somite.sim.terrain import hilly
from somite.tasks.locomotion import simulate_batch

from .conftest import quiet


def reference_step(graph: GraphArrays, h_prev, readings, sigmoid_hidden=False):
    """h_k from h_{k-1}: sensors read tanh(reading); others act(sum of h_prev * w + b)."""
    h = [0.0] * graph.n_nodes
    actuation = {}
    for n in range(graph.n_nodes):
        kind = graph.node_kind[n]
        if kind == SENSOR:
            h[n] = math.tanh(readings[graph.node_ref[n]])
            continue
        total = sum(h_prev[graph.src[e]] * graph.weight[e] + graph.bias[e]
                    for e in range(graph.n_edges) if graph.dst[e] == n)
        if kind == HIDDEN and sigmoid_hidden:
            h[n] = 1 / (1 + math.exp(-total))
        else:
            h[n] = math.tanh(total)
        if kind == ACTUATOR:
            actuation[graph.node_ref[n]] = h[n]
    return h, actuation


def graph(kinds, refs, edges) -> GraphArrays:
    src, dst, weight, bias = zip(*edges) if edges else ((), (), (), ())
    return GraphArrays(np.array(kinds, np.int32), np.array(refs, np.int32),
                       np.array(src, np.int32), np.array(dst, np.int32),
                       np.array(weight, float), np.array(bias, float))


S, H, A = SENSOR, HIDDEN, ACTUATOR
HAND_MADE = {
    # sensor -> actuator: one step of delay
    "direct": graph([S, A], [0, 0], [(0, 1, 2.0, 0.5)]),
    # sensor -> hidden -> actuator: two steps; two parallel paths into the actuator
    "chain": graph([S, H, A, S], [0, -1, 0, 1],
                   [(0, 1, 1.5, 0.1), (1, 2, -2.0, 0.3), (3, 2, 0.7, -0.2)]),
    # a cycle between two hidden nodes and a self-loop
    "cycle": graph([S, H, H, A], [0, -1, -1, 0],
                   [(0, 1, 1.0, 0.0), (1, 2, 1.2, 0.1), (2, 1, -0.9, 0.2), (2, 2, 0.5, 0.0),
                    (2, 3, 1.0, -0.1)]),
    # an isolated actuator and an isolated hidden node beside a working one
    "isolated": graph([S, A, A, H], [0, 0, 1, -1], [(0, 1, 1.0, 1.0)]),
}


@pytest.mark.parametrize("name", sorted(HAND_MADE))
@pytest.mark.parametrize("sigmoid_hidden", [False, True])
def test_graph_step_matches_reference(name, sigmoid_hidden):
    g = HAND_MADE[name]
    rng = np.random.default_rng(0)
    n_voxels = 2
    h_prev = np.zeros(g.n_nodes)
    h_next = np.zeros(g.n_nodes)
    ref_h = [0.0] * g.n_nodes
    for _ in range(12):
        readings = rng.random(2)
        actuation = np.zeros(n_voxels)
        graph_step(graph_of(g), h_prev, h_next, readings, actuation, sigmoid_hidden)
        ref_h, ref_actuation = reference_step(g, ref_h, readings, sigmoid_hidden)
        np.testing.assert_allclose(h_next, ref_h, rtol=0, atol=1e-14)
        for voxel, value in ref_actuation.items():
            assert abs(actuation[voxel] - value) < 1e-14
        h_prev[:] = h_next


def test_delays_and_isolated_nodes():
    g = HAND_MADE["chain"]
    h = np.zeros(g.n_nodes)
    out = np.zeros(g.n_nodes)
    actuation = np.zeros(1)
    # Step 1: the actuator sees only h_0 = 0 of its sources: tanh(sum of biases).
    graph_step(graph_of(g), h, out, np.array([0.9, 0.4]), actuation, False)
    assert actuation[0] == pytest.approx(math.tanh(0.3 - 0.2))
    assert out[1] == pytest.approx(math.tanh(0.1))  # hidden: only its bias so far
    iso = HAND_MADE["isolated"]
    h = np.zeros(4)
    out = np.zeros(4)
    actuation = np.full(2, 7.0)
    for sigmoid_hidden, hidden_value in ((False, 0.0), (True, 0.5)):
        graph_step(graph_of(iso), h, out, np.array([0.3]), actuation, sigmoid_hidden)
        assert actuation[1] == 0.0  # an isolated actuator rests
        assert out[3] == hidden_value  # act(0) for an isolated hidden node


def test_episode_drives_voxels_with_the_reference_controller(worm):
    """Feed the readings recorded in an episode to the reference: it must produce exactly
    the actuation the kernel applied, step by step."""
    g = random_graph(worm, 200, np.random.default_rng(5))
    _, trace = simulate_batch([worm], [hilly(1.0, 10.0, 1)], [g], quiet(duration=1.0).with_options(
        noise_sigma=0.01), seeds=3, record=True)
    h = [0.0] * g.n_nodes
    for k in range(1, trace.readings.shape[1]):
        h, actuation = reference_step(g, h, trace.readings[0, k])
        for voxel, value in actuation.items():
            assert abs(trace.actuation[0, k, voxel] - value) < 1e-12
