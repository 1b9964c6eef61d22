"""Initialisation, mutation operators, the operator roulette, and module partitions."""

from collections import Counter
from dataclasses import fields

import numpy as np
import pytest
from scipy.stats import chisquare

from somite.brain.genome import Edge, Genome, Node, next_id
from somite.errors import SomiteError
from somite.evolution.config import GAConfig
from somite.evolution.operators import (
    OPERATOR_NAMES,
    OPERATORS,
    WEIGHT_MUTATION,
    OperatorConfig,
    add_edge,
    add_node,
    initial_genome,
    mutate,
    mutate_edge,
    prune,
    remove_edge,
    remove_node,
)
from somite.sim.body import Body, Shape
from somite.sim.partition import Partition

# Sensors 0 (voxel (0,0)) and 2 (voxel (1,0)); actuators 1 and 3.
TINY_BODY = Body.build("2x1", "area")
TINY_BASE = (
    Node(0, 0, 0, "sensor", 0),
    Node(1, 0, 0, "actuator"),
    Node(2, 1, 0, "sensor", 0),
    Node(3, 1, 0, "actuator"),
)


def tiny(hidden=(), edges=((0, 1), (2, 3))):
    """The 2-voxel genome plus hidden nodes given as (id, x); edges given as (src, dst)."""
    nodes = TINY_BASE + tuple(Node(i, x, 0, "hidden") for i, x in hidden)
    return Genome(TINY_BODY, nodes, tuple(Edge(u, v, 0.1 * u - 0.2, 0.05 * v) for u, v in edges))


def pairs(genome):
    return {(e.src, e.dst) for e in genome.edges}


def ids(genome):
    return {n.id for n in genome.nodes}


@pytest.fixture(scope="module")
def worm():
    return initial_genome(Body.build("worm"), np.random.default_rng(3))


@pytest.fixture(scope="module")
def grown_worm(worm):
    """The worm with a dozen hidden nodes, grown by add_node."""
    rng = np.random.default_rng(4)
    genome = worm
    for _ in range(12):
        genome = add_node(genome, rng)
    return genome


def expect_error(field, build):
    with pytest.raises(SomiteError) as info:
        build()
    assert str(info.value).startswith(f"{field}="), str(info.value)


# -- initialisation -----------------------------------------------------------------------------


def test_initial_genome_is_reproducible_and_seed_dependent():
    body = Body.build("biped")
    a = initial_genome(body, np.random.default_rng(11))
    assert a == initial_genome(body, np.random.default_rng(11))
    assert a != initial_genome(body, np.random.default_rng(12))
    weights = np.array([[e.weight, e.bias] for e in a.edges])
    assert weights.min() >= -1 and weights.max() <= 1 and weights.std() > 0.3


# -- mutate_edge --------------------------------------------------------------------------------


def test_mutate_edge_moves_weight_and_bias_of_exactly_one_edge(grown_worm):
    child = mutate_edge(grown_worm, np.random.default_rng(0), sigma=0.7)
    assert child.nodes == grown_worm.nodes
    changed = [(a, b) for a, b in zip(grown_worm.edges, child.edges) if a != b]
    assert len(child.edges) == len(grown_worm.edges) and len(changed) == 1
    (before, after), = changed
    assert (before.src, before.dst) == (after.src, after.dst)
    assert before.weight != after.weight and before.bias != after.bias


def test_mutate_edge_steps_are_normal_with_sigma():
    rng = np.random.default_rng(1)
    parent = tiny()
    steps, chosen = [], Counter()
    for _ in range(3000):
        child = mutate_edge(parent, rng, sigma=0.7)
        for k, (a, b) in enumerate(zip(parent.edges, child.edges)):
            if a != b:
                chosen[k] += 1
                steps += [b.weight - a.weight, b.bias - a.bias]
    assert abs(np.std(steps) - 0.7) < 0.03 and abs(np.mean(steps)) < 0.03
    assert abs(chosen[0] - chosen[1]) < 4 * np.sqrt(3000 * 0.25)


def test_mutate_edge_with_zero_sigma_changes_nothing():
    parent = tiny()
    assert mutate_edge(parent, np.random.default_rng(0), sigma=0.0) == parent


# -- add_edge -----------------------------------------------------------------------------------


def test_add_edge_adds_one_valid_edge_and_keeps_the_rest(grown_worm):
    child = add_edge(grown_worm, np.random.default_rng(5))
    assert child.nodes == grown_worm.nodes
    assert child.edges[:-1] == grown_worm.edges
    new = child.edges[-1]
    kind = {n.id: n.kind for n in child.nodes}
    assert kind[new.src] != "actuator" and kind[new.dst] != "sensor" and new.src != new.dst
    assert (new.src, new.dst) not in pairs(grown_worm)
    assert -1 <= new.weight <= 1 and -1 <= new.bias <= 1


def test_add_edge_is_uniform_over_the_valid_new_pairs():
    parent = tiny(hidden=[(9, 0)], edges=[(0, 1), (2, 3), (0, 9), (9, 1)])
    # u in {0, 2, 9}, v in {1, 3, 9}; minus 9 -> 9 and the four existing edges.
    expected = {(0, 3), (2, 1), (2, 9), (9, 3)}
    rng = np.random.default_rng(6)
    counts = Counter()
    for _ in range(2000):
        new = add_edge(parent, rng).edges[-1]
        counts[(new.src, new.dst)] += 1
    assert set(counts) == expected
    assert chisquare(list(counts.values())).pvalue > 1e-3


def test_add_edge_without_candidates_returns_an_equal_copy():
    full = Genome(Body.build("1x1", "area"), TINY_BASE[:2], (Edge(0, 1, 0.3, 0.2),))
    assert add_edge(full, np.random.default_rng(0)) == full


def test_omega_biases_add_edge_towards_same_module_pairs(worm):
    partition = Partition.preset("worm-halves", worm.body.shape)
    # Candidate counts by hand: sources are the 40 sensors, targets the 12 actuators.
    sensors = [n for n in worm.nodes if n.kind == "sensor"]
    actuators = [n for n in worm.nodes if n.kind == "actuator"]
    same = sum(partition.same_module((s.x, s.y), (a.x, a.y)) for s in sensors for a in actuators)
    same -= 40  # the initial edges all lie inside one voxel
    cross = 40 * 12 - 40 - same
    fractions = {}
    for omega in (10.0, 0.1):
        rng = np.random.default_rng(7)
        n = 1500
        hits = 0
        for _ in range(n):
            new = add_edge(worm, rng, partition, omega).edges[-1]
            u, v = worm.nodes[new.src], worm.nodes[new.dst]
            hits += partition.same_module((u.x, u.y), (v.x, v.y))
        p = omega * same / (omega * same + cross)
        assert abs(hits / n - p) < 4 * np.sqrt(p * (1 - p) / n), (omega, hits / n, p)
        fractions[omega] = hits / n
    assert fractions[10.0] > 0.85 and fractions[0.1] < 0.15


def test_omega_one_or_no_partition_is_uniform(worm):
    partition = Partition.preset("paper", "worm")
    plain = add_edge(worm, np.random.default_rng(8))
    assert add_edge(worm, np.random.default_rng(8), partition, 1.0) == plain
    assert add_edge(worm, np.random.default_rng(8), None, 10.0) == plain


def test_partition_for_another_shape_is_rejected(worm):
    partition = Partition.preset("paper", "biped")
    expect_error("partition", lambda: add_edge(worm, np.random.default_rng(0), partition, 10.0))


# -- remove_edge and prune ----------------------------------------------------------------------


def test_remove_edge_prunes_exactly_the_isolated_hidden_nodes():
    # 8 is fed by sensor 0 only; 9 was isolated from the start; 7 sits on 2 -> 7 -> 3.
    parent = tiny(hidden=[(7, 1), (8, 0), (9, 0)], edges=[(0, 8), (2, 7), (7, 3)])
    expected = {
        (0, 8): {0, 1, 2, 3, 7},
        (2, 7): {0, 1, 2, 3, 7, 8},
        (7, 3): {0, 1, 2, 3, 7, 8},
    }
    rng = np.random.default_rng(9)
    seen = set()
    for _ in range(60):
        child = remove_edge(parent, rng)
        (gone,) = pairs(parent) - pairs(child)
        assert len(child.edges) == 2
        assert ids(child) == expected[gone]
        seen.add(gone)
    assert seen == set(expected)


def test_prune_removes_only_isolated_hidden_nodes():
    # Sensors and actuators stay even without edges; 8 and 9 are isolated hidden nodes.
    parent = tiny(hidden=[(7, 1), (8, 0), (9, 1)], edges=[(7, 7)])
    child = prune(parent)
    assert ids(child) == {0, 1, 2, 3, 7}
    assert child.edges == parent.edges
    assert prune(child) == child


# -- add_node -----------------------------------------------------------------------------------


def test_add_node_adds_a_hidden_node_between_u_and_v(grown_worm):
    child = add_node(grown_worm, np.random.default_rng(10))
    assert child.nodes[:-1] == grown_worm.nodes and child.edges[:-2] == grown_worm.edges
    node = child.nodes[-1]
    assert (node.kind, node.id, node.slot) == ("hidden", next_id(grown_worm), None)
    into, out = child.edges[-2:]
    assert into.dst == node.id == out.src
    kind = {n.id: n.kind for n in child.nodes}
    assert kind[into.src] != "actuator" and kind[out.dst] != "sensor"


def test_add_node_allows_u_equal_v_and_keeps_existing_edges():
    parent = tiny(hidden=[(7, 1)], edges=[(0, 1), (2, 3), (0, 7), (7, 3)])
    rng = np.random.default_rng(11)
    counts = Counter()
    for _ in range(3000):
        child = add_node(parent, rng)
        assert child.edges[:-2] == parent.edges
        into, out = child.edges[-2:]
        counts[(into.src, out.dst)] += 1
    # u in {0, 2, 7}, v in {1, 3, 7}: all nine pairs, already connected ones and 7 -> w -> 7.
    assert set(counts) == {(u, v) for u in (0, 2, 7) for v in (1, 3, 7)}
    assert chisquare(list(counts.values())).pvalue > 1e-3


def test_add_node_without_candidates_returns_an_equal_copy():
    lonely = Genome(Body.build("1x1", "none"), (Node(0, 0, 0, "actuator"),), ())
    assert add_node(lonely, np.random.default_rng(0)) == lonely


def placements(worm, placement, n=600, omega=2.0):
    """(u, v, voxel of w) for n add_node draws on the worm with the halves partition."""
    partition = Partition.preset("worm-halves", worm.body.shape)
    rng = np.random.default_rng(12)
    out = []
    for _ in range(n):
        child = add_node(worm, rng, partition, omega, placement)
        into, out_edge = child.edges[-2:]
        u, v, w = worm.nodes[into.src], worm.nodes[out_edge.dst], child.nodes[-1]
        out.append((partition.module_of(u.x, u.y), partition.module_of(v.x, v.y), (w.x, w.y)))
    return partition, out


def test_module_placement_keeps_the_node_inside_the_shared_module(worm):
    partition, draws = placements(worm, "module")
    inside = [(mu, partition.module_of(*w)) for mu, mv, w in draws if mu == mv]
    assert len(inside) > 100
    assert all(mu == mw for mu, mw in inside)
    # Same-module draws fill the whole module; cross-module draws land anywhere.
    assert len({w for mu, mv, w in draws if mu == mv == "back"}) == 6
    crossing = [partition.module_of(*w) for mu, mv, w in draws if mu != mv]
    assert set(crossing) == {"back", "front"}


def test_uniform_placement_ignores_modules(worm):
    partition, draws = placements(worm, "uniform")
    outside = [mu != partition.module_of(*w) for mu, mv, w in draws if mu == mv]
    assert 0.35 < np.mean(outside) < 0.65


@pytest.mark.parametrize("shape, name", [("worm", "worm-halves"), ("biped", "biped-legs")])
def test_omega_one_places_new_nodes_at_the_neutral_rate(shape, name):
    """omega = 1 is no bias at all: a node added between two nodes of one module lands in that
    module only as often as the module's share of the body's voxels, and on every voxel alike."""
    genome = initial_genome(Body.build(shape), np.random.default_rng(3))
    partition = Partition.preset(name, genome.body.shape)
    voxels = genome.body.shape.voxels
    rng = np.random.default_rng(15)
    inside, expected_inside, landed = 0, 0.0, Counter()
    for _ in range(3000):
        child = add_node(genome, rng, partition, 1.0, "module")
        into, out = child.edges[-2:]
        u, v, w = genome.nodes[into.src], genome.nodes[out.dst], child.nodes[-1]
        shared = partition.module_of(u.x, u.y)
        if shared != partition.module_of(v.x, v.y):
            continue
        inside += partition.module_of(w.x, w.y) == shared
        expected_inside += len(partition.voxels_of(shared)) / len(voxels)
        landed[(w.x, w.y)] += 1
    n = sum(landed.values())
    assert n > 500
    assert chisquare([inside, n - inside], [expected_inside, n - expected_inside]).pvalue > 1e-3
    assert chisquare([landed[xy] for xy in voxels]).pvalue > 1e-3


def test_omega_one_with_a_partition_draws_as_without(worm):
    partition = Partition.preset("worm-halves", worm.body.shape)
    for seed in range(20):
        plain = add_node(worm, np.random.default_rng(seed))
        assert add_node(worm, np.random.default_rng(seed), partition, 1.0, "module") == plain


def test_omega_biases_add_node_pairs(worm):
    partition = Partition.preset("worm-halves", worm.body.shape)
    rng = np.random.default_rng(13)
    n, hits = 1000, 0
    for _ in range(n):
        child = add_node(worm, rng, partition, 10.0)
        into, out = child.edges[-2:]
        u, v = worm.nodes[into.src], worm.nodes[out.dst]
        hits += partition.same_module((u.x, u.y), (v.x, v.y))
    # All 40 x 12 pairs count; each half has 6 actuators, so 40 x 6 pairs are same-module.
    p = 10 / 11
    assert abs(hits / n - p) < 4 * np.sqrt(p * (1 - p) / n)


# -- remove_node --------------------------------------------------------------------------------


def test_remove_node_removes_the_node_its_edges_and_newly_isolated_ones():
    # 0 -> 7 -> 8: removing 7 isolates 8; removing 8 leaves 7 fed by sensor 0.
    parent = tiny(hidden=[(7, 0), (8, 1)], edges=[(0, 1), (0, 7), (7, 8)])
    expected = {7: ({0, 1, 2, 3}, {(0, 1)}), 8: ({0, 1, 2, 3, 7}, {(0, 1), (0, 7)})}
    rng = np.random.default_rng(14)
    seen = set()
    for _ in range(40):
        child = remove_node(parent, rng)
        gone = 8 if 7 in ids(child) else 7
        assert (ids(child), pairs(child)) == expected[gone]
        seen.add(gone)
    assert seen == {7, 8}


def test_edge_operators_on_a_genome_without_edges_return_an_equal_copy():
    empty = tiny(edges=())
    rng = np.random.default_rng(0)
    for operator in (mutate_edge, remove_edge, remove_node):
        child = operator(empty, rng)
        assert child == empty and child is not empty


# -- every operator -----------------------------------------------------------------------------


@pytest.mark.parametrize("name", OPERATOR_NAMES)
def test_operators_leave_the_parent_alone_and_give_valid_children(grown_worm, name):
    before = grown_worm.to_dict()
    config = OperatorConfig(**{f"p_{n}": float(n == name) for n in OPERATOR_NAMES}, omega=10.0)
    partition = Partition.preset("paper", "worm")
    rng = np.random.default_rng(15)
    for _ in range(20):
        child, used = mutate(grown_worm, rng, config, partition)
        assert used == name
        assert Genome.from_dict(child.to_dict()) == child
    assert grown_worm.to_dict() == before


# -- the roulette -------------------------------------------------------------------------------


def test_mutate_picks_operators_with_the_configured_frequencies():
    parent = tiny(hidden=[(7, 0)], edges=[(0, 1), (0, 7), (7, 3)])
    config = OperatorConfig()
    rng = np.random.default_rng(16)
    n = 8000
    counts = Counter(mutate(parent, rng, config)[1] for _ in range(n))
    observed = [counts[name] for name in OPERATOR_NAMES]
    expected = [p * n for p in config.probabilities]
    assert sum(observed) == n
    assert chisquare(observed, expected).pvalue > 1e-3
    assert abs(counts["mutate_edge"] / n - 0.5) < 0.03


def test_zero_probabilities_are_never_picked():
    parent = tiny()
    rng = np.random.default_rng(17)
    ablation = OperatorConfig(
        p_mutate_edge=1, p_add_edge=0, p_remove_edge=0, p_add_node=0, p_remove_node=0
    )
    assert {mutate(parent, rng, ablation)[1] for _ in range(300)} == {"mutate_edge"}
    halves = OperatorConfig(
        p_mutate_edge=0, p_add_edge=2, p_remove_edge=0, p_add_node=2, p_remove_node=0
    )
    counts = Counter(mutate(parent, rng, halves)[1] for _ in range(1000))
    assert set(counts) == {"add_edge", "add_node"}
    assert abs(counts["add_edge"] - 500) < 4 * np.sqrt(250)


@pytest.mark.parametrize(
    "field, value",
    [
        ("p_add_edge", -0.1),
        ("p_add_node", float("nan")),
        ("p_remove_node", float("inf")),
        ("sigma", -1.0),
        ("omega", 0.0),
        ("omega", -2.0),
        ("node_placement", "voxel"),
        ("p_mutate_edge", "0.5"),
    ],
)
def test_operator_config_rejects_bad_values(field, value):
    expect_error(field, lambda: OperatorConfig(**{field: value}))


def test_every_operator_has_its_probability_field():
    weights = [f.name for f in fields(OperatorConfig) if f.name.startswith("p_")]
    assert weights == [f"p_{name}" for name in OPERATORS]
    assert OperatorConfig().probabilities == tuple(op.default for op in OPERATORS.values())


@pytest.mark.parametrize("name", OPERATOR_NAMES)
def test_weights_only_leaves_only_weight_mutation_on(grown_worm, name):
    """Whatever weight an operator was given, the ablation turns it off (weight mutation on)."""
    ga = GAConfig(weights_only=True, operators=OperatorConfig(**{f"p_{name}": 5.0}))
    variation = ga.variation()
    assert variation.probabilities == tuple(float(n == WEIGHT_MUTATION) for n in OPERATORS)
    assert (variation.sigma, variation.omega) == (ga.operators.sigma, ga.operators.omega)
    rng = np.random.default_rng(4)
    assert {mutate(grown_worm, rng, variation)[1] for _ in range(20)} == {WEIGHT_MUTATION}


def test_operator_config_needs_one_positive_probability():
    zeros = {f"p_{name}": 0 for name in OPERATOR_NAMES}
    expect_error("p_mutate_edge", lambda: OperatorConfig(**zeros))


def test_operator_config_round_trips_through_a_dict():
    config = OperatorConfig(omega=10.0, node_placement="uniform")
    assert OperatorConfig.from_dict(config.to_dict()) == config
    expect_error("p_crossover", lambda: OperatorConfig.from_dict({"p_crossover": 0.1}))


# -- partitions ---------------------------------------------------------------------------------


def test_worm_halves_preset():
    partition = Partition.preset("worm-halves", "worm")
    assert partition.grid_string() == "AAABBB/AAABBB"
    assert partition.module_of(2, 1) == "back" and partition.module_of(3, 0) == "front"
    assert partition.same_module((0, 0), (2, 1)) and not partition.same_module((2, 0), (3, 0))
    assert Partition.preset("paper", "worm") == partition


def test_biped_legs_preset_has_two_separate_legs():
    partition = Partition.preset("paper", "biped")
    assert partition.grid_string() == "ACCB/ACCB/A..B"
    assert partition.voxels_of("left-leg") == ((0, 0), (0, 1), (0, 2))
    assert partition.voxels_of("right-leg") == ((3, 0), (3, 1), (3, 2))
    assert partition.voxels_of("torso") == ((1, 1), (2, 1), (1, 2), (2, 2))
    assert not partition.same_module((0, 0), (3, 0))


def test_partition_presets_are_tied_to_their_shapes():
    expect_error("partition", lambda: Partition.preset("paper", "3x3"))
    expect_error("partition", lambda: Partition.preset("worm-halves", "biped"))
    expect_error("partition", lambda: Partition.preset("thirds", "worm"))


def test_partition_from_grid():
    shape = Shape.parse("biped")
    partition = Partition.from_grid("LTTR/LTTR/L..R", shape)
    assert partition.labels == ("L", "R", "L", "T", "T", "R", "L", "T", "T", "R")
    assert Partition.parse(partition.grid_string(), shape) == partition
    assert Partition.parse("biped-legs", shape).modules == ("left-leg", "right-leg", "torso")


@pytest.mark.parametrize(
    "grid, why",
    [
        ("AABBAA/AABBAA", "not 4-connected"),
        ("AAABBB", "rows"),
        ("AAA.BB/AAABBB", "'.'"),
        ("AAABB/AAABB", "rows"),
    ],
)
def test_partition_from_grid_rejects_bad_grids(grid, why):
    with pytest.raises(SomiteError, match="partition") as info:
        Partition.from_grid(grid, "worm")
    assert why in str(info.value)


def test_partition_needs_a_label_per_voxel():
    expect_error("partition.labels", lambda: Partition(Shape.parse("worm"), ("A",) * 11))
    expect_error("voxel", lambda: Partition.preset("paper", "worm").module_of(6, 0))
