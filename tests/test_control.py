"""The table of controller types (somite.brain.control): each type packs into its code and
fields, and the episode runs it as its own kernel would."""

from __future__ import annotations

import math

import numpy as np
import pytest

from somite.bench import random_graph
from somite.brain.control import CONTROLLER_TYPES, TYPE_CODE, ZERO, compile_controllers
from somite.brain.controllers import Sine, Table, Zero
from somite.errors import SomiteError, SomiteTypeError
from somite.sim.body import Body
from somite.sim.config import CONTROL_HZ
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import simulate_batch

from .conftest import quiet
from .test_controller import reference_step

WORM = Body.build("worm")
V = WORM.shape.n_voxels
EXAMPLES = {
    "zero": Zero(),
    "sine": Sine(1.5, 0.8, -0.7),
    "table": Table(np.random.default_rng(2).uniform(-1, 1, (7, V))),
    "graph": random_graph(WORM, 120, np.random.default_rng(3)),
}
TYPES = [pytest.param(entry, id=entry.name) for entry in CONTROLLER_TYPES]


def expected_actuation(spec, k: int, readings_k, h):
    """Step k's actuation (V,) of ``spec`` by hand; ``h`` the graph's state before step k."""
    x = np.array([x for x, _ in WORM.shape.voxels], dtype=float)
    if isinstance(spec, Sine):
        return spec.amp * np.sin(2 * math.pi * spec.freq * k / CONTROL_HZ + spec.phase * x), h
    if isinstance(spec, Table):
        return spec.rows[k % len(spec.rows)], h
    if isinstance(spec, Zero):
        return np.zeros(V), h
    h, actuation = reference_step(spec, h, readings_k)
    return np.array([actuation[v] for v in range(V)]), h


def test_every_type_has_an_example():
    assert set(EXAMPLES) == {entry.name for entry in CONTROLLER_TYPES}
    assert [TYPE_CODE[entry.name] for entry in CONTROLLER_TYPES] == list(
        range(len(CONTROLLER_TYPES)))


@pytest.mark.parametrize("entry", TYPES)
def test_a_type_packs_to_its_code_and_runs_as_its_kernel(entry):
    spec = EXAMPLES[entry.name]
    assert isinstance(spec, entry.spec)
    ctrl = compile_controllers([Zero(), spec], [V, V])
    assert ctrl.kind.tolist() == [ZERO, TYPE_CODE[entry.name]]
    assert all(len(field) == 2 for field in ctrl)
    _, trace = simulate_batch([WORM, WORM], [parse_terrain("flat")] * 2, [Zero(), spec],
                              quiet(duration=1.0, noise_sigma=0.01), seeds=4, record=True)
    assert not trace.actuation[0].any()  # its neighbour in the batch stays at rest
    h = [0.0] * getattr(spec, "n_nodes", 0)
    for k in range(1, trace.actuation.shape[1]):
        expected, h = expected_actuation(spec, k, trace.readings[1, k], h)
        np.testing.assert_allclose(trace.actuation[1, k, :V], expected, rtol=0, atol=1e-12)


def test_a_batch_pads_each_type_s_fields_to_its_longest():
    short, long = Table(np.ones((2, V))), Table(np.full((5, V), 0.5))
    ctrl = compile_controllers([short, Sine(), long, EXAMPLES["graph"]], [V] * 4)
    assert ctrl.table.shape == (4, 5, V)
    assert ctrl.table_period.tolist() == [2, 1, 5, 1]
    assert ctrl.sine.tolist()[1] == [1.0, 1.0, -1.0] and not ctrl.sine[[0, 2, 3]].any()
    graph = EXAMPLES["graph"]
    assert ctrl.n_nodes.tolist() == [0, 0, 0, graph.n_nodes]
    assert ctrl.edge_weight[3, : graph.n_edges].tolist() == graph.weight.tolist()


def test_unknown_controllers_and_misfit_tables_are_one_line_errors():
    with pytest.raises(SomiteTypeError, match=r"^controllers\[1\]='sine': expected a controller "
                       r"\(Zero\(\), Sine\(\.\.\.\), Table\(\.\.\.\), a compiled Genome\) or a "
                       r"Genome, not str$"):
        compile_controllers([Zero(), "sine"], [V, V])
    with pytest.raises(SomiteError, match=r"^controllers\[0\]='a table of 3 columns': its body "
                       r"has 12 voxels$"):
        compile_controllers([Table(np.zeros((4, 3)))], [V])
