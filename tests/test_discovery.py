"""Module discovery: enumeration of connected voxel sets, compactness, ties, the discover CLI."""

import csv
import itertools
import json

import numpy as np
import pytest

from somite.brain.genome import Edge, Genome, Node
from somite.cli import main
from somite.evolution.operators import OperatorConfig, initial_genome, mutate
from somite.modules.discovery import (
    connected_sets,
    discover,
    partition_around,
    rank_candidates,
)
from somite.sim.body import Body, Shape, is_connected
from somite.sim.partition import Partition

from .conftest import expect_error


def bare(shape: str = "worm") -> Genome:
    """Every sensor and actuator node of the paper's body, no edge; ids by initial_genome."""
    genome = initial_genome(Body.build(shape), np.random.default_rng(0))
    return Genome(genome.body, genome.nodes, ())


def with_edges(genome: Genome, pairs, hidden=()) -> Genome:
    """``genome`` plus edges given as ((x, y) of a sensor or hidden id, (x, y) of an actuator)."""
    sensor = {}
    actuator = {}
    for n in genome.nodes:
        if n.kind == "sensor" and n.slot == 0:
            sensor[(n.x, n.y)] = n.id
        if n.kind == "actuator":
            actuator[(n.x, n.y)] = n.id
    nodes = genome.nodes + tuple(hidden)
    edges = tuple(
        Edge(sensor.get(src, src), actuator.get(dst, dst), w, b) for src, dst, w, b in pairs
    )
    return Genome(genome.body, nodes, edges)


# -- enumeration ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape, counts",
    [("biped", [12, 20, 29, 38]), ("worm", [16, 28, 43, 64])],
    ids=["biped", "worm"],
)
def test_enumeration_counts(shape, counts):
    sets = connected_sets(Shape.parse(shape), 2, 5)
    assert [sum(len(s) == k for s in sets) for k in (2, 3, 4, 5)] == counts


@pytest.mark.parametrize("shape", ["biped", "worm", "1101/1111/0110"])
def test_enumeration_is_every_connected_subset(shape):
    """Brute force over all subsets: the enumeration misses none and adds nothing."""
    shape = Shape.parse(shape)
    cells = shape.voxels
    brute = {
        combo
        for k in range(1, shape.n_voxels + 1)
        for combo in itertools.combinations(range(len(cells)), k)
        if is_connected({cells[i] for i in combo})
    }
    found = connected_sets(shape, 1, shape.n_voxels)
    assert len(found) == len(set(found))
    assert set(found) == brute


def test_biped_l_triomino_is_a_candidate():
    """The authors' partial enumeration misses it (docs/original-system.md section 7)."""
    shape = Shape.parse("biped")
    l_shape = tuple(sorted(shape.index(*v) for v in [(0, 1), (0, 2), (1, 2)]))
    assert l_shape in connected_sets(shape, 3, 3)


# -- compactness and the choice -------------------------------------------------------------------

BLOCK = [(2, 0), (3, 0), (2, 1), (3, 1)]


def block_genome() -> Genome:
    """Edges only inside the 2x2 block at x in {2, 3}: a ring through its four voxels, plus
    edges within each voxel. Every proper subset of the block cuts part of the ring."""
    ring = [
        ((2, 0), (3, 0), 0.5, 0.25),
        ((3, 0), (3, 1), -0.5, 0.75),
        ((3, 1), (2, 1), 1.0, -0.25),
        ((2, 1), (2, 0), 0.3, 0.3),
    ]
    own = [(v, v, 0.2, -0.1) for v in BLOCK]
    return with_edges(bare(), ring + own)


def test_discovery_finds_the_block():
    genome = block_genome()
    partition = discover(genome)
    assert partition.voxels_of("A") == tuple(sorted(BLOCK, key=lambda v: (v[1], v[0])))
    # The rest splits into its two components, lettered left to right.
    assert partition.grid_string() == "BBAACC/BBAACC"
    best = rank_candidates(genome)[0]
    assert best.compactness == 1.0 and best.crossing == 0.0
    # Supersets of the block tie on c and inside; the smaller set wins.
    runner_up = rank_candidates(genome)[1]
    assert runner_up.compactness == 1.0 and runner_up.size == 5


def test_compactness_scores():
    genome = with_edges(
        bare(),
        [((0, 0), (1, 0), 1.0, 1.0), ((1, 0), (2, 0), 0.5, 0.0), ((0, 0), (0, 0), 0.25, 0.25)],
    )
    scored = {c.voxels: c for c in rank_candidates(genome)}
    pair = scored[((0, 0), (1, 0))]
    assert (pair.inside, pair.crossing) == (2.5, 0.5)
    assert pair.compactness == pytest.approx(2.5 / 3.0)
    far = scored[((4, 0), (5, 0))]
    assert (far.inside, far.crossing) == (0.0, 0.0) and np.isnan(far.compactness)


def test_ties_prefer_larger_inside_then_smaller_then_lowest():
    # Two isolated pairs with c = 1: the heavier one wins although it lies further right.
    genome = with_edges(bare(), [((0, 0), (1, 0), 0.5, 0.0), ((4, 1), (5, 1), 1.0, 0.0)])
    assert rank_candidates(genome)[0].voxels == ((4, 1), (5, 1))
    # Larger inside beats smaller size: a light pair against a heavier 2x2 block, both c = 1.
    block = [((4, 0), (5, 0), 1.0, 0.0), ((5, 0), (5, 1), 1.0, 0.0), ((5, 1), (4, 1), 1.0, 0.0)]
    genome = with_edges(bare(), [((0, 0), (1, 0), 0.5, 0.0), *block])
    assert rank_candidates(genome)[0].voxels == ((4, 0), (5, 0), (4, 1), (5, 1))
    # Same weights: the set starting lowest and leftmost wins.
    genome = with_edges(bare(), [((0, 0), (1, 0), 1.0, 0.0), ((4, 1), (5, 1), 1.0, 0.0)])
    ranked = rank_candidates(genome)
    assert ranked[0].voxels == ((0, 0), (1, 0))
    assert ranked[1].voxels == ((4, 1), (5, 1))


def test_sets_with_nothing_inside_rank_last():
    """Only an edge within voxel (5, 1): sets without it (0/0) must not win by order."""
    genome = with_edges(bare(), [((5, 1), (5, 1), 1.0, 0.0)])
    ranked = rank_candidates(genome)
    assert ranked[0].voxels == ((5, 0), (5, 1))
    inside = [c.inside > 0 for c in ranked]
    assert inside == sorted(inside, reverse=True)


def test_discovery_on_an_evolved_genome_gives_a_valid_partition():
    rng = np.random.default_rng(5)
    genome = initial_genome(Body.build("biped"), rng)
    config = OperatorConfig(p_add_edge=0.5, p_add_node=0.5, p_mutate_edge=0.0,
                            p_remove_edge=0.0, p_remove_node=0.0)
    for _ in range(30):
        genome, _ = mutate(genome, rng, config)
    ranked = rank_candidates(genome, 2, 5)
    assert len(ranked) == 12 + 20 + 29 + 38
    keys = [c.compactness for c in ranked if c.inside > 0]
    assert keys == sorted(keys, reverse=True)
    partition = discover(genome)
    assert set(partition.voxels_of("A")) == set(ranked[0].voxels)
    # The other modules are the connected pieces of the rest of the body.
    rest = {v for v in genome.body.shape.voxels if v not in set(ranked[0].voxels)}
    assert {v for m in partition.modules if m != "A" for v in partition.voxels_of(m)} == rest
    assert 2 <= len(partition.modules) <= 1 + 10 - ranked[0].size


def test_partition_around_the_whole_body_and_splits():
    shape = Shape.parse("biped")
    whole = partition_around(shape, shape.voxels)
    assert whole.modules == ("A",)
    # Taking the torso leaves the two legs, two modules.
    torso = [(1, 1), (2, 1), (1, 2), (2, 2)]
    assert partition_around(shape, torso).grid_string() == "BAAC/BAAC/B..C"


def test_bad_bounds():
    genome = block_genome()
    expect_error("b_min", lambda: rank_candidates(genome, 3, 2))
    expect_error("b_min", lambda: rank_candidates(genome, 0, 2))
    expect_error("b_max", lambda: rank_candidates(genome, 2, 13))
    expect_error("b_max", lambda: connected_sets(Shape.parse("biped"), 1, 11))
    assert len(connected_sets(Shape.parse("biped"), 10, 10)) == 1


# -- the command ----------------------------------------------------------------------------------


def test_discover_command(tmp_path, capsys):
    source = block_genome().save(tmp_path / "g.json")
    out = tmp_path / "out"
    assert main(["discover", str(source), "--out", str(out)]) == 0
    data = json.loads((out / "partition.json").read_text())
    assert data["grid"] == "BBAACC/BBAACC"
    assert data["best"]["compactness"] == 1.0 and data["n_candidates"] == 16 + 28 + 43 + 64
    assert data["scores"]["A"]["crossing"] == 0.0
    with open(out / "candidates.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 151 and rows[0]["voxels"] == "2,0 3,0 2,1 3,1"
    assert rows[0]["rank"] == "1" and float(rows[0]["compactness"]) == 1.0
    # The written partition is usable wherever a partition spec is.
    again = Partition.parse(str(out / "partition.json"), Shape.parse("worm"))
    assert again == Partition.from_grid("BBAACC/BBAACC", "worm")


@pytest.mark.parametrize(
    "extra, field",
    [(["--min", "4", "--max", "3"], "b_min"), (["--min", "0"], "b_min"),
     (["--max", "13"], "b_max")],
    ids=["min-over-max", "min-zero", "max-over-size"],
)
def test_discover_command_bad_bounds_write_nothing(tmp_path, capsys, extra, field):
    source = block_genome().save(tmp_path / "g.json")
    out = tmp_path / "out"
    assert main(["discover", str(source), "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"somite discover: error: {field}=") and "\n" not in err
    assert not out.exists()


def test_partition_file_of_unknown_version(tmp_path):
    path = tmp_path / "p.json"
    data = {"format": "somite-partition", "version": 9, "grid": "AAABBB/AAABBB"}
    path.write_text(json.dumps(data))
    expect_error("partition", lambda: Partition.parse(str(path), Shape.parse("worm")))


def test_partition_file_round_trip_keeps_labels(tmp_path):
    legs = Partition.preset("biped-legs", "biped")
    path = legs.save(tmp_path / "legs.json", note="kept")
    assert json.loads(path.read_text())["note"] == "kept"
    assert Partition.load(path) == Partition.parse(str(path), "biped") == legs
    assert Partition.load(path).modules == ("left-leg", "right-leg", "torso")
    expect_error("partition", lambda: Partition.parse(str(path), "worm"))  # another shape
    data = legs.to_dict()
    del data["modules"]["torso"]
    path.write_text(json.dumps(data))
    expect_error("partition", lambda: Partition.load(path))  # voxels without a module


def test_hidden_nodes_count_in_their_voxel():
    genome = bare()
    hidden = Node(999, 0, 1, "hidden")
    genome = with_edges(genome, [((0, 0), 999, 1.0, 0.0), (999, (1, 1), 1.0, 0.0)], [hidden])
    best = rank_candidates(genome)[0]
    assert set(best.voxels) == {(0, 0), (0, 1), (1, 1)}
