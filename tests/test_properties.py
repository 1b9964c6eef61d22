"""Properties that must hold for any input (hypothesis)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from somite.brain.compile import compile_genome
from somite.brain.genome import Genome
from somite.errors import SomiteError
from somite.evolution.operators import OperatorConfig, initial_genome, mutate
from somite.sim.body import Body, Shape, is_connected
from somite.sim.partition import Partition

grids = st.integers(1, 5).flatmap(
    lambda width: st.lists(
        st.text(alphabet="01", min_size=width, max_size=width), min_size=1, max_size=4
    )
).map("/".join)


@given(grids)
def test_any_grid_parses_to_itself_or_fails_with_one_line(grid):
    cells = {
        (x, len(grid.split("/")) - 1 - r)
        for r, row in enumerate(grid.split("/"))
        for x, c in enumerate(row)
        if c == "1"
    }
    try:
        shape = Shape.parse(grid)
    except SomiteError as error:
        assert str(error).startswith("shape=") and "\n" not in str(error)
        assert not is_connected(cells)
        return
    assert is_connected(cells)
    assert Shape.parse(shape.grid_string()) == shape
    assert shape.n_voxels == len(cells)


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(["worm", "biped"]), st.integers(0, 2**32 - 1), st.integers(1, 60),
       st.sampled_from([0.1, 1.0, 10.0]))
def test_any_mutation_sequence_keeps_a_valid_genome(shape, seed, steps, omega):
    rng = np.random.default_rng(seed)
    body = Body.build(shape)
    partition = Partition.preset("paper", body.shape)
    config = OperatorConfig(omega=omega)
    genome = initial_genome(body, rng)
    for _ in range(steps):
        genome, _ = mutate(genome, rng, config, partition)
    # Valid by construction (Genome validates), survives a round trip, and compiles with
    # every sensor and actuator wired to its own reading and voxel.
    assert Genome.from_compact(genome.to_compact()) == genome
    arrays = compile_genome(genome)
    assert arrays.n_nodes == genome.n_nodes and arrays.n_edges == genome.n_edges
    assert sorted(arrays.node_ref[arrays.node_kind == 0]) == list(range(body.n_readings))
    assert sorted(arrays.node_ref[arrays.node_kind == 2]) == list(range(body.shape.n_voxels))
    assert np.all(arrays.node_kind[arrays.src] != 2) and np.all(arrays.node_kind[arrays.dst] != 0)
