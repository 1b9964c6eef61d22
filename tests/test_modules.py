"""Disassembly, reassembly (homogeneous and heterogeneous), cut ratios, rho, the reassemble CLI."""

import json
import math
from collections import Counter

import numpy as np
import pytest

from somite.brain.genome import Edge, Genome, Node
from somite.cli import main
from somite.evolution.operators import initial_genome, prune
from somite.modules.module import CutRatio, Module, cut, pooled
from somite.modules.reassembly import Take, paper_takes, reassemble, receiver_for
from somite.modules.transfer import rho, transferability
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.partition import Partition
from somite.tasks.validation import evaluate, validation_terrains

from .conftest import evolved, expect_error


def row() -> Genome:
    """A hand-made 4x1 robot, one area sensor per voxel, partition AABB.

    Sensor of voxel i is 10 i, its actuator 10 i + 1; hidden 100 sits in voxel 1, hidden 101 in
    voxel 2 with only crossing edges. Weights |w| + |b| in the comments.
    """
    body = Body.build("4x1", "area")
    nodes = [Node(10 * i, i, 0, "sensor", 0) for i in range(4)]
    nodes += [Node(10 * i + 1, i, 0, "actuator") for i in range(4)]
    nodes += [Node(100, 1, 0, "hidden"), Node(101, 2, 0, "hidden")]
    edges = [
        Edge(0, 1, 1.0, 0.0),  # A inside, 1
        Edge(0, 11, 0.5, 0.5),  # A inside, 1
        Edge(10, 100, 1.0, -1.0),  # A inside, 2
        Edge(100, 21, 2.0, 0.0),  # crossing A -> B, 2
        Edge(20, 11, -1.0, -1.0),  # crossing B -> A, 2
        Edge(0, 101, 1.0, 0.0),  # crossing A -> B, 1
        Edge(101, 1, 0.0, 1.0),  # crossing B -> A, 1
        Edge(30, 31, 3.0, 1.0),  # B inside, 4
        Edge(20, 31, 1.0, 0.0),  # B inside, 1
    ]
    return Genome(body, tuple(nodes), tuple(edges))


ROW_PARTITION = "AABB"


def as_sets(genome: Genome):
    return set(genome.nodes), set(genome.edges)


# -- disassembly and eta --------------------------------------------------------------------------


def test_cut_counts_on_a_hand_made_genome():
    genome = row()
    parts = cut(genome, Partition.from_grid(ROW_PARTITION, genome.body.shape))
    a, b = parts.module("A"), parts.module("B")
    assert a.voxels == ((0, 0), (1, 0)) and b.voxels == ((2, 0), (3, 0))
    assert {n.id for n in a.nodes} == {0, 1, 10, 11, 100}
    assert {n.id for n in b.nodes} == {20, 21, 30, 31, 101}
    assert [(e.src, e.dst) for e in a.edges] == [(0, 1), (0, 11), (10, 100)]
    assert [(e.src, e.dst) for e in b.edges] == [(30, 31), (20, 31)]
    assert {(e.src, e.dst) for e in parts.crossing} == {(100, 21), (20, 11), (0, 101), (101, 1)}
    # Per module: crossing edges touching it over all edges touching it.
    assert parts.ratio("A") == CutRatio(7, 4, 10.0, 6.0)
    assert parts.ratio("B") == CutRatio(6, 4, 11.0, 6.0)
    assert parts.ratio("A").eta_num == pytest.approx(4 / 7)
    assert parts.ratio("B").eta_weight == pytest.approx(6 / 11)
    # The authors' pooled eta over one donor: crossing over all edges.
    assert parts.total == CutRatio(9, 4, 15.0, 6.0)
    assert parts.total.eta_num == pytest.approx(4 / 9)
    assert parts.total.eta_weight == pytest.approx(6 / 15)


def test_self_reassembly_gives_back_the_genome_minus_crossing_edges():
    genome = row()
    partition = Partition.from_grid(ROW_PARTITION, genome.body.shape)
    result = reassemble(genome.body, partition, {m: (genome, partition, m) for m in "AB"})
    expected_edges = {e for e in genome.edges if (e.src, e.dst) in
                      {(0, 1), (0, 11), (10, 100), (30, 31), (20, 31)}}
    # Hidden 101 had crossing edges only: pruned. Every other node keeps its id.
    expected_nodes = {n for n in genome.nodes if n.id != 101}
    assert as_sets(result.genome) == (expected_nodes, expected_edges)
    a, b = result.grafts
    assert (a.n_nodes_kept, a.n_edges_kept, a.n_hidden_pruned) == (5, 3, 0)
    assert (b.n_nodes_kept, b.n_edges_kept, b.n_hidden_pruned) == (4, 2, 1)
    for g in result.grafts:
        assert g.n_nodes_dropped == g.n_edges_dropped == g.n_nodes_added == 0
    # eta_num is the share of edges the reassembly lost.
    lost = (genome.n_edges - result.genome.n_edges) / genome.n_edges
    assert result.pooled.eta_num == pytest.approx(lost) == pytest.approx(4 / 9)


@pytest.mark.parametrize(
    "shape, preset, seed",
    [("worm", "worm-halves", 3), ("biped", "biped-legs", 4), ("worm", "AABBCC/ABBBCC", 5)],
    ids=["worm", "biped", "worm-3-modules"],
)
def test_self_reassembly_of_evolved_genomes(shape, preset, seed):
    genome = evolved(shape, seed)
    partition = Partition.parse(preset, genome.body.shape)
    parts = cut(genome, partition)
    result = reassemble(
        genome.body, partition, {m: Take(genome, partition, m) for m in partition.modules}
    )
    crossing = set(parts.crossing)
    assert crossing, "the test genome should have crossing edges"
    kept = [e for e in genome.edges if e not in crossing]
    expected = prune(Genome(genome.body, genome.nodes, kept))
    assert as_sets(result.genome) == as_sets(expected)
    lost = genome.n_edges - result.genome.n_edges
    assert lost == len(crossing)
    assert parts.total.eta_num == pytest.approx(lost / genome.n_edges)
    # Every edge is inside one module or crossing: the per-module counts add up.
    inside = sum(len(m.edges) for m in parts.modules)
    assert inside + len(crossing) == genome.n_edges
    assert sum(r.n_edges for r in parts.ratios) == inside + 2 * len(crossing)


def test_pooled_eta_is_over_both_donors_in_full():
    d1, d2 = evolved("worm", 11), evolved("worm", 12)
    halves = Partition.preset("worm-halves", "worm")
    c1, c2 = cut(d1, halves), cut(d2, halves)
    total = pooled([c1, c2])
    assert total.n_edges == d1.n_edges + d2.n_edges
    assert total.n_cut == len(c1.crossing) + len(c2.crossing)
    weights = [abs(e.weight) + abs(e.bias) for e in c1.crossing + c2.crossing]
    assert total.weight_cut == pytest.approx(sum(weights))
    # A donor listed twice counts once.
    assert pooled([c1, c1, c2]) == total


def test_module_is_a_valid_robot_of_its_own():
    genome = evolved("biped", 6)
    torso = cut(genome, Partition.preset("biped-legs", "biped")).module("torso")
    own = torso.genome()
    assert own.body.shape.grid_string() == "11/11"
    assert torso.origin == (1, 1) and torso.relative().origin == (0, 0)
    assert len(own.nodes) == len(torso.nodes) and len(own.edges) == len(torso.edges)
    # A module missing an actuator node is refused.
    nodes = tuple(n for n in torso.nodes if not (n.kind == "actuator" and (n.x, n.y) == (1, 1)))
    edges = tuple(e for e in torso.edges if e.dst in {n.id for n in nodes})
    expect_error("nodes", lambda: Module("t", torso.voxels, torso.sensors, nodes, edges))
    expect_error(
        "module.voxels",
        lambda: Module("t", ((0, 0), (2, 0)), (("area",), ("area",)), (), ()),
    )


# -- homogeneous reassembly from two donors -------------------------------------------------------


def describe(genome_or_module, ids):
    """(src, dst, w, b) with nodes as (kind, x, y, slot); hidden ids forgotten."""
    nodes = {n.id: n for n in genome_or_module.nodes}
    key = lambda n: (n.kind, n.x, n.y, n.slot)  # noqa: E731
    return Counter(
        (key(nodes[e.src]), key(nodes[e.dst]), e.weight, e.bias)
        for e in genome_or_module.edges
        if e.src in ids and e.dst in ids
    )


def test_homogeneous_worm_back_from_donor1_front_from_donor2():
    d1, d2 = evolved("worm", 21), evolved("worm", 22)
    halves = Partition.preset("worm-halves", "worm")
    result = reassemble(
        d1.body, halves, {"back": (d1, halves, "back"), "front": (d2, halves, "front")}
    )
    genome = result.genome
    back, front = cut(d1, halves).module("back"), cut(d2, halves).module("front")
    in_back = {n.id for n in genome.nodes if n.x <= 2}
    in_front = {n.id for n in genome.nodes if n.x >= 3}
    # The back comes first, so it keeps donor 1's ids exactly (minus pruned hidden nodes).
    kept_back = prune(Genome(d1.body, d1.nodes, [e for e in d1.edges if e in set(back.edges)]))
    assert {n for n in genome.nodes if n.id in in_back} == {
        n for n in kept_back.nodes if n.x <= 2
    }
    assert {e for e in genome.edges if e.src in in_back} == set(back.edges)
    # The front is donor 2's front, up to the ids of its hidden nodes.
    assert describe(genome, in_front) == describe(front, {n.id for n in front.nodes})
    assert not [e for e in genome.edges if (e.src in in_back) != (e.dst in in_back)]
    hidden = lambda nodes: sum(n.kind == "hidden" for n in nodes)  # noqa: E731
    assert hidden(genome.nodes) == hidden(back.nodes) + hidden(front.nodes) - sum(
        g.n_hidden_pruned for g in result.grafts
    )
    assert result.homogeneous
    assert [r.eta_num for r in result.ratios] == [
        cut(d1, halves).ratio("back").eta_num, cut(d2, halves).ratio("front").eta_num
    ]


def test_paper_default_and_report_number_the_donors_as_given(monkeypatch):
    import somite.modules.reassembly as reassembly

    d1, d2 = evolved("worm", 21), evolved("worm", 22)
    halves = Partition.preset("worm-halves", "worm")
    donors = [(d1, halves), (d2, halves)]
    body, receiver = receiver_for(donors)
    assert body == d1.body and receiver == halves
    calls = []
    monkeypatch.setattr(reassembly, "cut", lambda g, p: calls.append(g) or cut(g, p))
    report = reassemble(body, receiver, paper_takes(receiver, donors), donors).to_dict()
    assert calls == [d1, d2]  # each donor cut once, the report included
    rows = [(m["module"], m["donor"], m["donor_module"]) for m in report["modules"]]
    assert rows == [("back", 1, "back"), ("front", 2, "front")]
    assert report["donors"][1]["cut"] == cut(d2, halves).total.to_dict()
    assert report["kind"] == "homogeneous" and report["receiver"]["partition"] == "AAABBB/AAABBB"
    # Numbers follow the donors given, not the order of use; an unused donor is still listed.
    def numbers(takes):
        report = reassemble(body, receiver, takes, donors).to_dict()
        return [m["donor"] for m in report["modules"]], len(report["donors"])

    assert numbers({"back": (d2, halves, "back"), "front": (d1, halves, "front")}) == ([2, 1], 2)
    assert numbers({"back": (d1, halves, "back"), "front": (d1, halves, "front")}) == ([1, 1], 2)
    other = Partition.from_grid("AABBBB/AABBBB", "worm")
    expect_error("donor2", lambda: paper_takes(receiver, [(d1, halves), (d2, other)]))


# -- heterogeneous reassembly ---------------------------------------------------------------------


def test_heterogeneous_biped_legs_from_biped_torso_from_worm_front():
    biped = evolved("biped", 31)
    worm = initial_genome(Body.build("worm"), np.random.default_rng(32))
    legs = Partition.preset("biped-legs", "biped")
    halves = Partition.preset("worm-halves", "worm")
    result = reassemble(
        biped.body, legs,
        {
            "left-leg": (biped, legs, "left-leg"),
            "right-leg": (biped, legs, "right-leg"),
            "torso": (worm, halves, "front"),
        },
    )
    genome = result.genome
    assert genome.body == biped.body and not result.homogeneous
    torso = dict(zip(legs.modules, result.grafts))["torso"]
    # Corners aligned: worm (3, 0) -> biped (1, 1); column x = 5 has no counterpart.
    assert torso.offset == (-2, 1)
    assert (torso.n_voxels_matched, torso.n_voxels_dropped, torso.n_voxels_empty) == (4, 2, 0)
    # Dropped: the touch sensors of (3, 0), (4, 0) and all 8 + 9 nodes of (5, 0), (5, 1).
    assert torso.n_nodes_dropped == 2 + 8 + 9
    assert torso.n_edges_dropped == 2 + 7 + 8
    assert (torso.n_nodes_kept, torso.n_edges_kept, torso.n_nodes_added) == (12, 8, 0)
    # The worm's (3, 1) vy -> actuator edge is now biped (1, 2)'s vy -> actuator edge.
    source = {n.id: n for n in worm.nodes}
    [vy_edge] = [
        e for e in worm.edges if (source[e.src].x, source[e.src].y, source[e.src].slot) == (3, 1, 2)
    ]
    nodes = {n.id: n for n in genome.nodes}
    mapped = [
        e for e in genome.edges
        if (nodes[e.src].x, nodes[e.src].y, nodes[e.src].slot) == (1, 2, 2)
    ]
    assert [(e.weight, e.bias, nodes[e.dst].kind, nodes[e.dst].x, nodes[e.dst].y)
            for e in mapped] == [(vy_edge.weight, vy_edge.bias, "actuator", 1, 2)]
    # It simulates; rho is computed on the same terrains for all three robots.
    measured = transferability(
        genome, biped, worm, validation_terrains(1), SimConfig(duration=2.0)
    )
    assert all(math.isfinite(v) for v in measured.means)
    assert measured.rho == pytest.approx(rho(*measured.means))
    direct = evaluate([genome], validation_terrains(1), SimConfig(duration=2.0))
    assert direct[0, 0] == measured.v_reassembled[0]


def test_heterogeneous_lidar_maps_by_kind_and_component():
    """A worm's front column onto the biped's right leg: lidar l2 is slot 5 there, 3 here."""
    worm_body = Body.build("worm")
    rng = np.random.default_rng(41)
    worm = initial_genome(worm_body, rng)
    by_slot = {(n.x, n.y, n.slot): n.id for n in worm.nodes if n.kind == "sensor"}
    actuator = {(n.x, n.y): n.id for n in worm.nodes if n.kind == "actuator"}
    hidden = Node(500, 5, 1, "hidden")
    extra = (
        Edge(by_slot[(5, 1, 5)], 500, 0.25, 0.5),  # l2 of (5, 1) -> hidden
        Edge(500, actuator[(5, 0)], -0.75, 0.125),
    )
    worm = Genome(worm_body, worm.nodes + (hidden,), worm.edges + extra)
    column = Partition.from_grid("AAAAAB/AAAAAB", "worm")
    biped = initial_genome(Body.build("biped"), rng)
    sides = Partition.from_grid("ABBC/ABBC/A..C", "biped")
    result = reassemble(
        biped.body, sides,
        {"A": (biped, sides, "A"), "B": (biped, sides, "B"), "C": (worm, column, "B")},
    )
    nodes = {n.id: n for n in result.genome.nodes}
    [into_hidden] = [e for e in result.genome.edges if nodes[e.dst].kind == "hidden"]
    src = nodes[into_hidden.src]
    assert (src.x, src.y, src.slot, into_hidden.weight) == (3, 1, 3, 0.25)
    [out_of_hidden] = [e for e in result.genome.edges if nodes[e.src].kind == "hidden"]
    dst = nodes[out_of_hidden.dst]
    assert (dst.kind, dst.x, dst.y, out_of_hidden.weight) == ("actuator", 3, 0, -0.75)
    assert nodes[into_hidden.dst].x == 3 and nodes[into_hidden.dst].y == 1
    report = dict(zip(sides.modules, result.grafts))["C"]
    # (5, 1)'s vx, vy are dropped; (3, 2) gets no donor voxel: 8 readings + actuator added.
    assert report.n_nodes_dropped == 2 and report.n_voxels_empty == 1
    assert report.n_nodes_added == 9
    plain = [n for n in result.genome.nodes if (n.x, n.y) == (3, 2)]
    assert len(plain) == 9
    assert not [e for e in result.genome.edges if nodes[e.src] in plain or nodes[e.dst] in plain]


# -- rho ------------------------------------------------------------------------------------------


def test_rho_is_eq_4():
    assert rho(1.5, 1.0, 2.0) == pytest.approx(1.0)
    assert rho(0.6, 1.0, 0.2) == pytest.approx(1.0)
    assert rho(0.3, 1.0, 0.2) == pytest.approx(0.5)
    assert math.isnan(rho(1.0, 1.0, -1.0))
    assert math.isnan(rho(1.0, math.nan, 1.0))


# -- bad inputs -----------------------------------------------------------------------------------


def test_bad_reassembly_inputs():
    worm = evolved("worm", 51, steps=5)
    halves = Partition.preset("worm-halves", "worm")
    legs = Partition.preset("biped-legs", "biped")
    expect_error("partition", lambda: cut(worm, legs))
    expect_error("parts", lambda: reassemble(worm.body, halves, {"back": (worm, halves, "back")}))
    expect_error(
        "parts",
        lambda: reassemble(
            worm.body, halves,
            {"back": (worm, halves, "back"), "front": (worm, halves, "front"), "x": None},
        ),
    )
    expect_error(
        "parts[front].label",
        lambda: reassemble(
            worm.body, halves, {"back": (worm, halves, "back"), "front": (worm, halves, "torso")}
        ),
    )
    expect_error(
        "parts[front].partition",
        lambda: reassemble(
            worm.body, halves, {"back": (worm, halves, "back"), "front": (worm, legs, "torso")}
        ),
    )
    expect_error("receiver_partition", lambda: reassemble(worm.body, legs, {}))


# -- the command ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def donor_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("donors")
    paths = {}
    for name, shape, seed in (("w1", "worm", 61), ("w2", "worm", 62), ("b1", "biped", 63)):
        paths[name] = evolved(shape, seed).save(folder / f"{name}.json")
    return paths


def test_reassemble_command_homogeneous(tmp_path, donor_files, capsys):
    out = tmp_path / "out"
    rc = main([
        "reassemble", str(donor_files["w1"]), str(donor_files["w2"]),
        "--partition", "worm-halves", "--out", str(out), "--validation", "1", "--duration", "2",
    ])
    assert rc == 0
    written = sorted(p.name for p in out.iterdir())
    assert written == ["reassembled.json", "report.csv", "report.json"]
    report = json.loads((out / "report.json").read_text())
    genome = Genome.load(out / "reassembled.json")
    assert report["kind"] == "homogeneous"
    assert [(m["module"], m["donor"]) for m in report["modules"]] == [("back", 1), ("front", 2)]
    d1, d2 = Genome.load(donor_files["w1"]), Genome.load(donor_files["w2"])
    halves = Partition.preset("worm-halves", "worm")
    n_cut = len(cut(d1, halves).crossing) + len(cut(d2, halves).crossing)
    assert report["pooled"]["n_cut"] == n_cut
    assert report["modules"][0]["eta_num"] == cut(d1, halves).ratio("back").eta_num
    validation = report["validation"]
    assert len(validation["terrains"]) == 1
    assert validation["rho"] == pytest.approx(
        validation["v_reassembled"] / ((validation["v_donor1"] + validation["v_donor2"]) / 2)
    )
    assert report["receiver"]["edges"] == genome.n_edges
    lines = (out / "report.csv").read_text().splitlines()
    assert lines[0].startswith("module,donor,donor_module") and len(lines) == 3


def test_reassemble_command_heterogeneous_take(tmp_path, donor_files):
    out = tmp_path / "out"
    rc = main([
        "reassemble", str(donor_files["b1"]), str(donor_files["w1"]), "--out", str(out),
        "--take", "torso=DONOR2:front,left-leg=DONOR1:left-leg,right-leg=DONOR1:right-leg",
        "--validation", "0", "--draw",
    ])
    assert rc == 0
    report = json.loads((out / "report.json").read_text())
    assert report["kind"] == "heterogeneous"
    assert Genome.load(out / "reassembled.json").body.shape.grid_string() == "1111/1111/1001"
    torso = [m for m in report["modules"] if m["module"] == "torso"][0]
    assert (torso["donor"], torso["donor_module"], torso["voxels_dropped"]) == (2, "front", 2)
    assert "validation" not in report
    assert report["draw"] == "reassembled.png"
    assert (out / "reassembled.png").read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize(
    "extra, field",
    [
        (["--partition", "AAA/BBB"], "partition"),  # does not cover the worm
        (["--partition", "biped-legs"], "partition"),  # another shape's preset
        (["--take", "back=DONOR1:back"], "take"),  # front missing
        (["--take", "back=DONOR3:back,front=DONOR2:front"], "take"),
        (["--take", "back=DONOR1:torso,front=DONOR2:front"], "take"),
        (["--validation", "-1"], "validation"),
        (["--receiver-shape", "biped"], "donor1"),  # shapes differ and no --take
    ],
    ids=["partition-not-covering", "partition-other-shape", "take-missing", "take-donor",
         "take-module", "validation", "needs-take"],
)
def test_reassemble_command_bad_input_writes_nothing(tmp_path, donor_files, capsys, extra, field):
    out = tmp_path / "out"
    rc = main(["reassemble", str(donor_files["w1"]), str(donor_files["w2"]), "--out", str(out),
               "--validation", "0", *extra])
    assert rc == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("somite reassemble: error: ") and "\n" not in err
    assert err.split("error: ", 1)[1].startswith(f"{field}="), err
    assert not out.exists()
