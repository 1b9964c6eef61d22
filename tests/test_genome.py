"""Genome validation, JSON files and compilation to GraphArrays."""

import json
import math
import os

import numpy as np
import pytest

from somite.brain.compile import compile_genome
from somite.brain.genome import Edge, Genome, Node, next_id
from somite.brain.kinds import ACTUATOR, HIDDEN, SENSOR
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.sim.body import Body

from .conftest import expect_error


@pytest.fixture(scope="module")
def worm():
    return initial_genome(Body.build("worm"), np.random.default_rng(0))


@pytest.fixture(scope="module")
def biped():
    return initial_genome(Body.build("biped"), np.random.default_rng(1))


def tiny(extra_nodes=(), edges=None):
    """Two voxels with an area sensor each: sensors 10, 30, actuators 11, 31 (ids not dense)."""
    body = Body.build("2x1", "area")
    nodes = (
        Node(31, 1, 0, "actuator"),
        Node(10, 0, 0, "sensor", 0),
        Node(30, 1, 0, "sensor", 0),
        Node(11, 0, 0, "actuator"),
    ) + tuple(extra_nodes)
    if edges is None:
        edges = (Edge(10, 11, 0.5, -0.25), Edge(30, 31, -1.0, 0.125))
    return Genome(body, nodes, tuple(edges))




# -- sizes and layout ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape, n_nodes, n_edges", [("biped", 45, 35), ("worm", 52, 40)], ids=["biped", "worm"]
)
def test_initial_sizes_match_table_1(shape, n_nodes, n_edges):
    genome = initial_genome(Body.build(shape), np.random.default_rng(7))
    assert (genome.n_nodes, genome.n_edges, genome.size) == (n_nodes, n_edges, n_nodes + n_edges)
    assert not [n for n in genome.nodes if n.kind == "hidden"]


def test_worm_node_ids_follow_the_original_layout(worm):
    by_id = {n.id: n for n in worm.nodes}
    # docs/original-system.md section 3: (5,0) -> 15-21 / act 22; (5,1) -> 43-50 / act 51.
    assert [(by_id[i].x, by_id[i].y, by_id[i].slot) for i in range(15, 22)] == [
        (5, 0, s) for s in range(7)
    ]
    assert (by_id[22].kind, by_id[22].x, by_id[22].y) == ("actuator", 5, 0)
    assert [by_id[i].slot for i in range(43, 51)] == list(range(8))
    assert (by_id[51].kind, by_id[51].x, by_id[51].y) == ("actuator", 5, 1)
    assert (by_id[26].kind, by_id[26].x, by_id[26].y) == ("actuator", 0, 1)


def test_biped_node_ids_follow_the_original_layout(biped):
    by_id = {n.id: n for n in biped.nodes}
    assert (by_id[10].kind, by_id[10].x, by_id[10].y) == ("actuator", 3, 0)
    assert [(by_id[i].x, by_id[i].y) for i in (36, 43)] == [(3, 2), (3, 2)]
    assert (by_id[44].kind, by_id[44].x, by_id[44].y) == ("actuator", 3, 2)
    # Each initial edge joins a sensor to the actuator of its own voxel.
    for edge in biped.edges:
        u, v = by_id[edge.src], by_id[edge.dst]
        assert (u.kind, v.kind, u.x, u.y) == ("sensor", "actuator", v.x, v.y)
        assert -1 <= edge.weight <= 1 and -1 <= edge.bias <= 1


def test_next_id_is_max_plus_one():
    assert next_id(tiny()) == 32
    assert next_id(tiny([Node(99, 0, 0, "hidden")])) == 100


# -- validation ---------------------------------------------------------------------------------


def test_edge_into_a_sensor_is_rejected():
    message = expect_error("edges[2].dst", lambda: tiny(edges=[
        Edge(10, 11, 0.1, 0.1), Edge(30, 31, 0.1, 0.1), Edge(10, 30, 0.1, 0.1)
    ]))
    assert "sensor" in message


def test_edge_from_an_actuator_is_rejected():
    expect_error("edges[0].src", lambda: tiny(edges=[Edge(11, 31, 0.1, 0.1)]))


def test_duplicate_edge_is_rejected():
    expect_error("edges[1]", lambda: tiny(edges=[Edge(10, 11, 0.1, 0.1), Edge(10, 11, 0.3, 0.1)]))


def test_edge_to_a_missing_node_is_rejected():
    expect_error("edges[0].dst", lambda: tiny(edges=[Edge(10, 77, 0.1, 0.1)]))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_weight_and_bias_are_rejected(value):
    expect_error("edges[0].weight", lambda: tiny(edges=[Edge(10, 11, value, 0.1)]))
    expect_error("edges[0].bias", lambda: tiny(edges=[Edge(10, 11, 0.1, value)]))


def test_node_outside_the_body_is_rejected():
    message = expect_error("nodes[4]", lambda: tiny([Node(50, 2, 0, "hidden")]))
    assert "(2, 0)" in message


def test_duplicate_node_id_is_rejected():
    expect_error("nodes[4].id", lambda: tiny([Node(10, 0, 0, "hidden")]))


def test_missing_actuator_is_rejected():
    body = Body.build("2x1", "area")
    nodes = (Node(0, 0, 0, "sensor", 0), Node(1, 0, 0, "actuator"), Node(2, 1, 0, "sensor", 0))
    message = expect_error("nodes", lambda: Genome(body, nodes, ()))
    assert "(1, 0)" in message and "actuator" in message


def test_missing_and_repeated_sensor_readings_are_rejected():
    body = Body.build("2x1", "area")
    actuators = (Node(1, 0, 0, "actuator"), Node(3, 1, 0, "actuator"))
    missing = actuators + (Node(0, 0, 0, "sensor", 0),)
    assert "slot 0" in expect_error("nodes", lambda: Genome(body, missing, ()))
    twice = missing + (Node(2, 1, 0, "sensor", 0), Node(4, 0, 0, "sensor", 0))
    expect_error("nodes[4].slot", lambda: Genome(body, twice, ()))
    out_of_range = actuators + (Node(0, 0, 0, "sensor", 0), Node(2, 1, 0, "sensor", 1))
    expect_error("nodes[3].slot", lambda: Genome(body, out_of_range, ()))


def test_wrong_kind_and_misplaced_slot_are_rejected():
    expect_error("nodes[4].kind", lambda: tiny([Node(50, 0, 0, "neuron")]))
    expect_error("nodes[4].slot", lambda: tiny([Node(50, 0, 0, "hidden", 0)]))


def test_bool_and_float_ids_are_rejected():
    expect_error("nodes[4].id", lambda: tiny([Node(2.0, 0, 0, "hidden")]))
    expect_error("edges[0].src", lambda: tiny(edges=[Edge(True, 11, 0.1, 0.1)]))


# -- files --------------------------------------------------------------------------------------


def grown(genome):
    """``genome`` plus a hidden node in a 2-cycle with an actuator-free pair of edges."""
    h = next_id(genome)
    edges = genome.edges + (Edge(0, h, 0.1 + 1e-12, -0.3), Edge(h, h, 1 / 3, 2e-300))
    return Genome(genome.body, genome.nodes + (Node(h, 1, 1, "hidden"),), edges)


def test_save_then_load_gives_an_equal_genome(tmp_path, worm):
    genome = grown(worm)
    path = genome.save(tmp_path / "g.json")
    loaded = Genome.load(path)
    assert loaded == genome
    assert [p.name for p in tmp_path.iterdir()] == ["g.json"]  # no temp file left behind
    data = json.loads(path.read_text())
    assert (data["format"], data["version"]) == ("somite-genome", 1)
    assert data["body"] == worm.body.to_dict()


def test_save_replaces_an_existing_file(tmp_path, worm, biped):
    path = tmp_path / "g.json"
    worm.save(path)
    biped.save(path)
    assert Genome.load(path) == biped


def test_saved_file_mode_follows_the_umask(tmp_path, worm):
    umask = os.umask(0o022)
    os.umask(umask)
    path = worm.save(tmp_path / "g.json")
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_index_arrays_are_read_only(worm):
    with pytest.raises(ValueError):
        worm.index.kind[0] = 2
    assert worm.index.ids.tolist() == list(range(52))


def test_compact_form_round_trips_on_one_line(biped):
    genome = grown(biped)
    text = genome.to_compact()
    assert "\n" not in text
    assert Genome.from_compact(text) == genome
    assert Genome.from_dict(genome.to_dict()) == genome


def write(tmp_path, data):
    path = tmp_path / "bad.json"
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def test_load_reports_bad_json(tmp_path):
    path = write(tmp_path, '{"format": "somite-genome", "version": 1,')
    message = expect_error("genome", lambda: Genome.load(path))
    assert "not valid JSON" in message and "bad.json" in message


def test_load_reports_a_missing_file(tmp_path):
    expect_error("genome", lambda: Genome.load(tmp_path / "nope.json"))


def test_load_reports_wrong_version_and_format(tmp_path, worm):
    data = worm.to_dict()
    expect_error("version", lambda: Genome.load(write(tmp_path, {**data, "version": 2})))
    expect_error("format", lambda: Genome.load(write(tmp_path, {**data, "format": "jgea"})))
    expect_error("genome", lambda: Genome.from_dict([1, 2]))


def test_load_reports_an_edge_into_a_sensor(tmp_path, worm):
    data = worm.to_dict()
    data["edges"].append({"src": 0, "dst": 1, "weight": 0.1, "bias": 0.2})
    expect_error("edges[40].dst", lambda: Genome.load(write(tmp_path, data)))


def test_load_reports_a_node_outside_the_body(tmp_path, worm):
    data = worm.to_dict()
    data["nodes"].append({"id": 500, "x": 6, "y": 0, "kind": "hidden"})
    expect_error("nodes[52]", lambda: Genome.load(write(tmp_path, data)))


def test_load_reports_a_missing_actuator(tmp_path, worm):
    data = worm.to_dict()
    data["nodes"] = [n for n in data["nodes"] if n["id"] != 51]
    data["edges"] = [e for e in data["edges"] if e["dst"] != 51]
    assert "(5, 1)" in expect_error("nodes", lambda: Genome.load(write(tmp_path, data)))


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_load_rejects_non_finite_numbers(tmp_path, worm, literal):
    text = json.dumps(worm.to_dict())
    weight = json.dumps(worm.edges[3].weight)
    text = text.replace(f'"weight": {weight}', f'"weight": {literal}', 1)
    assert literal in text
    expect_error("edges[3].weight", lambda: Genome.load(write(tmp_path, text)))


def test_load_reports_malformed_entries(tmp_path, worm):
    data = worm.to_dict()
    data["edges"][5] = {"src": 0, "dst": 2}
    expect_error("edges[5]", lambda: Genome.from_dict(data))
    data = worm.to_dict()
    data["nodes"] = "all of them"
    expect_error("nodes", lambda: Genome.from_dict(data))


def test_saved_files_are_strict_json(tmp_path, worm):
    def refuse(constant):
        raise AssertionError(f"non-standard JSON constant {constant}")

    path = worm.save(tmp_path / "g.json")
    json.loads(path.read_text(), parse_constant=refuse)


# -- compilation --------------------------------------------------------------------------------


def test_compile_maps_worm_sensors_to_readings(worm):
    arrays = compile_genome(worm)
    readings = worm.body.readings
    by_id = {n.id: i for i, n in enumerate(worm.nodes)}
    voxel_50 = worm.body.shape.index(5, 0)
    # Worm voxel (5,0) reads a, t, l0..l4 (docs/original-system.md section 3): nodes 15-21.
    expected = [("area", 0), ("touch", 0)] + [("lidar", c) for c in range(5)]
    got = [readings[arrays.node_ref[by_id[i]]] for i in range(15, 22)]
    assert [(r.voxel, r.kind, r.component) for r in got] == [(voxel_50, *e) for e in expected]
    assert arrays.node_kind[by_id[15]] == SENSOR
    assert (arrays.node_kind[by_id[22]], arrays.node_ref[by_id[22]]) == (ACTUATOR, voxel_50)
    # (2,1): nodes 31-33 read a, vx, vy; actuator 34 drives voxel 8.
    got = [readings[arrays.node_ref[by_id[i]]] for i in (31, 32, 33)]
    assert [(r.kind, r.component) for r in got] == [("area", 0), ("velocity", 0), ("velocity", 1)]
    assert {r.voxel for r in got} == {worm.body.shape.index(2, 1)} == {8}
    assert arrays.node_ref[by_id[34]] == 8
    assert sorted(arrays.node_ref[arrays.node_kind == SENSOR]) == list(range(40))


def test_compile_translates_ids_to_positions_and_copies_parameters():
    genome = tiny(
        [Node(7, 1, 0, "hidden")],
        [Edge(30, 7, 0.5, 0.25), Edge(7, 11, -2.0, 0.75), Edge(7, 7, 0.125, 0.0)],
    )
    arrays = compile_genome(genome)
    assert arrays.node_kind.tolist() == [ACTUATOR, SENSOR, SENSOR, ACTUATOR, HIDDEN]
    assert arrays.node_ref.tolist() == [1, 0, 1, 0, -1]
    assert arrays.src.tolist() == [2, 4, 4]
    assert arrays.dst.tolist() == [4, 3, 4]
    assert arrays.weight.tolist() == [0.5, -2.0, 0.125]
    assert arrays.bias.tolist() == [0.25, 0.75, 0.0]
    assert arrays.node_kind.dtype == arrays.node_ref.dtype == arrays.src.dtype == np.int32
    assert arrays.weight.dtype == np.float64


def test_compile_empty_edge_set():
    arrays = compile_genome(tiny(edges=()))
    assert arrays.n_edges == 0 and arrays.n_nodes == 4
    assert arrays.src.dtype == np.int32


def test_compiled_genome_drives_the_simulation(worm):
    from somite.sim.config import SimConfig
    from somite.sim.terrain import parse_terrain
    from somite.tasks.locomotion import simulate_batch

    arrays = compile_genome(worm)
    still = Genome(worm.body, worm.nodes, ())
    outcomes, _ = simulate_batch(
        [worm.body] * 2,
        [parse_terrain("flat")] * 2,
        [arrays, compile_genome(still)],
        SimConfig(duration=2.0, transient=0.5),
    )
    assert all(o.finite for o in outcomes)
    # A controller without edges leaves every voxel at rest; the evolved one must move it.
    assert outcomes[0].final_com != outcomes[1].final_com


def test_fast_and_detailed_validation_agree():
    """Genomes are checked by a vectorised pass first; it must never accept what the
    item-by-item pass (which writes the error messages) rejects."""
    import dataclasses

    from somite.brain import genome as module

    rng = np.random.default_rng(0)
    base = initial_genome(Body.build("biped"), rng)
    base = Genome(base.body, base.nodes + (Node(45, 1, 1, "hidden"),),
                  base.edges + (Edge(0, 45, 0.1, 0.2), Edge(45, 10, 0.3, 0.4)))
    table = module.body_table(base.body)
    values = {
        "id": [-1, 3, 45, 1000, True, 2.0], "x": [0, 3, 4, -1, True], "y": [0, 2, 3],
        "kind": ["sensor", "hidden", "actuator", "neuron"], "slot": [None, 0, 1, 7, 8, True],
        "src": [0, 10, 44, 45, 999, True], "dst": [0, 2, 10, 45, 999],
        "weight": [0.5, math.nan, math.inf, 1, True], "bias": [0.1, -math.inf],
    }
    accepted = 0
    for _ in range(400):
        nodes, edges = list(base.nodes), list(base.edges)
        for _ in range(int(rng.integers(1, 3))):
            if rng.random() < 0.5:
                i, name = int(rng.integers(len(nodes))), str(rng.choice(list(values)[:5]))
                pick = values[name][int(rng.integers(len(values[name])))]
                nodes[i] = dataclasses.replace(nodes[i], **{name: pick})
            elif rng.random() < 0.2:
                edges.append(edges[int(rng.integers(len(edges)))])
            else:
                i, name = int(rng.integers(len(edges))), str(rng.choice(list(values)[5:]))
                pick = values[name][int(rng.integers(len(values[name])))]
                edges[i] = dataclasses.replace(edges[i], **{name: pick})
        fast = module._fast_index(tuple(nodes), tuple(edges), table) is not None
        try:
            position, kinds, _, _ = module._check_nodes(tuple(nodes), table)
            module._check_edges(tuple(edges), position, kinds)
            valid = True
        except SomiteError:
            valid = False
        assert fast <= valid
        accepted += valid
    assert 0 < accepted < 400
