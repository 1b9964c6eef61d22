"""Hostile input, strict readers (issue 23): genome, body, partition and module files whose
values would be coerced, duplicated or overflow later are refused in one line that names the
field and the value; ``assemble`` refuses a body over the side limit; node ids never overflow."""

from __future__ import annotations

import copy
import json
import re

import numpy as np
import pytest

from somite.brain.genome import MAX_NODE_ID, Edge, Genome, Node, fresh_ids, next_id
from somite.cli import main
from somite.errors import SomiteError
from somite.limits import MAX_SHAPE_SIDE
from somite.sim.body import Body, Shape
from somite.sim.partition import Partition

from .conftest import evolved

LONG = "1" * 5000
"""An integer over Python's int-string limit (4300 digits)."""
DEEP = "[" * 100_000 + "]" * 100_000
"""JSON nested past Python's recursion limit."""


def cli(capsys, *args, expected: int = 2) -> str:
    """Run ``somite ARGS``; for a failure, its one stderr line (no traceback)."""
    capsys.readouterr()
    try:
        code = main([str(a) for a in args])
    except SystemExit as stop:  # argparse's errors
        code = stop.code
    captured = capsys.readouterr()
    assert code == expected, captured.err
    if expected == 0:
        return captured.out
    err = captured.err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# -- fixtures -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def donor() -> Genome:
    return evolved("worm", 23, steps=20)


@pytest.fixture(scope="module")
def donor_data(donor) -> dict:
    return donor.to_dict()


def write_genome(tmp_path, data: dict | str, name: str = "genome.json"):
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else json.dumps(data))
    return path


def export(capsys, tmp_path, genome, partition: str = "worm-halves", expected: int = 2,
           module: str = "front"):
    """``somite module export``: reads a genome and a partition, writes one module file."""
    out = tmp_path / "out" / f"{module}.json"
    text = cli(capsys, "module", "export", genome, "--partition", partition, "--module", module,
               "--out", out, expected=expected)
    assert out.exists() == (expected == 0)
    assert expected == 0 or not (tmp_path / "out").exists()  # nothing written
    return text


# -- genome files: the body's sensors -------------------------------------------------------------


@pytest.mark.parametrize("value", [1.9, "1", True, 1.0, None, [1]])
def test_a_sensor_coordinate_must_be_a_json_integer(capsys, tmp_path, donor_data, value):
    data = copy.deepcopy(donor_data)
    data["body"]["sensors"][1]["x"] = value
    err = export(capsys, tmp_path, write_genome(tmp_path, data))
    assert err == (f"somite module: error: body.sensors[1].x={value!r}: voxel coordinates are "
                   "JSON integers\n")


@pytest.mark.parametrize("literal", ["1e999", "-1e999", "Infinity", "NaN"])
def test_a_sensor_coordinate_of_infinity_is_one_line(capsys, tmp_path, donor_data, literal):
    """JSON 1e999 reads as infinity; int(inf) was an uncaught OverflowError."""
    data = copy.deepcopy(donor_data)
    data["body"]["sensors"][1]["y"] = "@"
    text = json.dumps(data).replace('"@"', literal)
    err = export(capsys, tmp_path, write_genome(tmp_path, text))
    assert err.startswith("somite module: error: body.sensors[1].y=")
    assert err.endswith(": voxel coordinates are JSON integers\n")
    with pytest.raises(SomiteError, match=r"^body\.sensors\[1\]\.y="):
        Body.from_dict(json.loads(text)["body"])


@pytest.mark.parametrize("cell", [(7, 0), (-1, 0), (0, 2), (10**30, 0)])
def test_a_sensor_outside_the_body_is_refused(capsys, tmp_path, donor_data, cell):
    data = copy.deepcopy(donor_data)
    data["body"]["sensors"][1].update(x=cell[0], y=cell[1])
    err = export(capsys, tmp_path, write_genome(tmp_path, data))
    assert err == (f"somite module: error: body.sensors[1]={cell!r}: not a voxel of shape "
                   "111111/111111\n")


def test_a_voxel_listed_twice_is_refused(capsys, tmp_path, donor_data):
    data = copy.deepcopy(donor_data)
    sensors = data["body"]["sensors"]
    sensors.append(copy.deepcopy(sensors[0]))
    err = export(capsys, tmp_path, write_genome(tmp_path, data))
    assert err == (f"somite module: error: body.sensors[{len(sensors) - 1}]=(0, 0): voxel "
                   "listed twice\n")


def test_a_sensor_listed_twice_in_a_voxel_is_refused(capsys, tmp_path, donor_data):
    data = copy.deepcopy(donor_data)
    data["body"]["sensors"][0]["kinds"].append("area")
    err = export(capsys, tmp_path, write_genome(tmp_path, data))
    assert err == ("somite module: error: body.sensors[0].kinds='area': voxel (0, 0) lists this "
                   "sensor twice\n")


@pytest.mark.parametrize("field, value, why", [
    ("kinds", "area", "expected a list of"),
    ("kinds", ["area", 3], "unknown sensor kind"),
    ("kinds", ["sonar"], "unknown sensor kind"),
])
def test_sensor_kinds_are_a_list_of_known_names(tmp_path, donor_data, field, value, why):
    data = copy.deepcopy(donor_data)
    data["body"]["sensors"][0][field] = value
    with pytest.raises(SomiteError, match=rf"^body\.sensors\[0\]\.kinds=.*: {why}"):
        Genome.from_dict(data)


@pytest.mark.parametrize("shape", [111111, ["111111", "111111"], None])
def test_the_body_shape_must_be_a_string(donor_data, shape):
    data = copy.deepcopy(donor_data)
    data["body"]["shape"] = shape
    with pytest.raises(SomiteError, match=r"^body\.shape="):
        Genome.from_dict(data)


def test_a_voxel_keeps_the_order_of_its_sensors(worm):
    """The order fixes what each slot means: reading a file must not re-sort it."""
    data = worm.to_dict()
    top = next(item for item in data["sensors"] if item["kinds"] == ["area", "velocity"])
    top["kinds"] = ["velocity", "area"]
    body = Body.from_dict(data)
    assert body.sensors[worm.shape.index(top["x"], top["y"])] == ("velocity", "area")
    assert Body.from_dict(body.to_dict()) == body


def test_a_valid_body_still_reads_back(worm, biped):
    for body in (worm, biped, Body.build("3x2", "all"), Body.build("worm", "none")):
        assert Body.from_dict(body.to_dict()) == body
    assert Body.from_dict({"shape": "biped", "sensors": "paper"}) == biped


# -- genome files: node ids -----------------------------------------------------------------------


@pytest.mark.parametrize("value", [True, False, 1.0, "3", 2**63, -1])
def test_a_node_id_must_be_an_integer_in_range(capsys, tmp_path, donor_data, value):
    data = copy.deepcopy(donor_data)
    data["nodes"][1]["id"] = value
    err = export(capsys, tmp_path, write_genome(tmp_path, data))
    assert err.startswith(f"somite module: error: nodes[1].id={value!r}: ")


def _with_top_id(genome: Genome) -> Genome:
    """``genome`` with its largest node id renamed MAX_NODE_ID (2**63 - 1, a valid id)."""
    old = max(genome.position)
    new = {old: MAX_NODE_ID}
    nodes = [Node(new.get(n.id, n.id), n.x, n.y, n.kind, n.slot) for n in genome.nodes]
    edges = [Edge(new.get(e.src, e.src), new.get(e.dst, e.dst), e.weight, e.bias)
             for e in genome.edges]
    return Genome(genome.body, nodes, edges)


def test_the_largest_node_id_does_not_overflow_when_the_genome_grows(tmp_path, donor):
    """An id of 2**63 - 1 is valid; the next one was 2**63, refused in the middle of a run."""
    from somite.evolution.operators import OperatorConfig, mutate

    top = _with_top_id(donor)
    top.save(tmp_path / "top.json")
    assert Genome.load(tmp_path / "top.json") == top
    fresh = next_id(top)
    assert fresh not in top.position and 0 <= fresh < len(top.nodes) + 1
    grow = OperatorConfig(p_mutate_edge=0.0, p_add_edge=0.0, p_remove_edge=0.0, p_add_node=1.0,
                          p_remove_node=0.0)
    rng = np.random.default_rng(0)
    genome = top
    for _ in range(5):
        genome, _ = mutate(genome, rng, grow)
    assert genome.n_nodes > top.n_nodes and max(genome.position) == MAX_NODE_ID
    genome.save(tmp_path / "grown.json")
    assert Genome.load(tmp_path / "grown.json") == genome


def test_fresh_ids_are_above_the_largest_while_they_fit():
    assert fresh_ids([0, 1, 5], 3) == [6, 7, 8]
    assert fresh_ids([], 2) == [0, 1]
    assert fresh_ids([MAX_NODE_ID - 2], 2) == [MAX_NODE_ID - 1, MAX_NODE_ID]
    assert fresh_ids([0, 2, MAX_NODE_ID], 3) == [1, 3, 4]


# -- genome files: JSON itself --------------------------------------------------------------------


@pytest.mark.parametrize("text, why", [
    (f'{{"format": "somite-genome", "version": {LONG}}}',
     "not valid JSON (an integer of more than 4300 digits)"),
    (DEEP, "not valid JSON (nested too deeply)"),
])
def test_genome_json_errors_are_those_of_every_file(capsys, tmp_path, text, why):
    from somite._io import read_json

    genome = write_genome(tmp_path, text)
    err = export(capsys, tmp_path, genome)
    assert err == f"somite module: error: genome={str(genome)!r}: {why}\n"
    with pytest.raises(SomiteError) as info:  # the same words as a partition file's
        read_json(genome, "partition")
    assert str(info.value) == f"partition={str(genome)!r}: {why}"
    with pytest.raises(SomiteError, match=rf"^genome=.*: {re.escape(why)}$"):
        Genome.from_compact(text)


def test_a_valid_genome_is_still_read(capsys, tmp_path, donor):
    donor.save(tmp_path / "genome.json")
    out = export(capsys, tmp_path, tmp_path / "genome.json", expected=0)
    assert "module 'front'" in out
    assert Genome.from_compact(donor.to_compact()) == donor


# -- partition files ------------------------------------------------------------------------------


@pytest.fixture()
def partition_file(tmp_path, donor):
    donor.save(tmp_path / "genome.json")
    data = Partition.preset("worm-halves", "worm").to_dict()

    def write(change) -> str:
        changed = copy.deepcopy(data)
        change(changed)
        path = tmp_path / "partition.json"
        path.write_text(json.dumps(changed).replace('"@"', "1e999"))
        return str(path)

    return write


def _set_cell(value):
    def change(data):
        data["modules"]["back"][1] = value
    return change


@pytest.mark.parametrize("cell", [[4.5, 1.2], [1.0, 0], ["1", 0], [True, 0], [1, None],
                                  [1, 0, 0], [1], "10", {"x": 1, "y": 0}])
def test_a_partition_cell_must_be_two_json_integers(capsys, tmp_path, partition_file, cell):
    path = partition_file(_set_cell(cell))
    err = export(capsys, tmp_path, tmp_path / "genome.json", path)
    assert err == (f"somite module: error: partition={path!r}: modules['back'][1]={cell!r}: a "
                   "cell is [x, y] with integer x and y\n")


def test_a_partition_cell_of_infinity_is_one_line(capsys, tmp_path, partition_file):
    path = partition_file(_set_cell(["@", 0]))
    err = export(capsys, tmp_path, tmp_path / "genome.json", path)
    assert err == (f"somite module: error: partition={path!r}: modules['back'][1]=[inf, 0]: a "
                   "cell is [x, y] with integer x and y\n")


@pytest.mark.parametrize("cell, why", [
    ([9, 0], "not a voxel of shape 111111/111111"),
    ([1, -1], "not a voxel of shape 111111/111111"),
    ([0, 0], "voxel listed twice in this module"),
])
def test_a_partition_cell_is_a_voxel_of_the_shape_once(capsys, tmp_path, partition_file, cell,
                                                       why):
    path = partition_file(_set_cell(cell))
    err = export(capsys, tmp_path, tmp_path / "genome.json", path)
    assert err == f"somite module: error: partition={path!r}: modules['back'][1]={cell!r}: {why}\n"


def test_a_partition_cell_in_two_modules_is_refused(capsys, tmp_path, partition_file):
    path = partition_file(lambda data: data["modules"]["front"].append([0, 0]))
    err = export(capsys, tmp_path, tmp_path / "genome.json", path)
    assert err == (f"somite module: error: partition={path!r}: modules['front'][6]=[0, 0]: voxel "
                   "also in module 'back'\n")


@pytest.mark.parametrize("change, why", [
    (lambda data: data["modules"]["back"].pop(), "voxel (2, 1) is in no module"),
    (lambda data: data["modules"].update(extra=[]), "modules['extra']=[]: expected a non-empty"),
    (lambda data: data.update(version=True), "version True unsupported"),
    (lambda data: data.update(shape=11), "shape=11: expected a string"),
])
def test_other_partition_mistakes_are_one_line(capsys, tmp_path, partition_file, change, why):
    path = partition_file(change)
    err = export(capsys, tmp_path, tmp_path / "genome.json", path)
    assert err.startswith(f"somite module: error: partition={path!r}: {why}")


def test_a_valid_partition_file_is_still_read(capsys, tmp_path, partition_file):
    path = partition_file(lambda data: None)
    export(capsys, tmp_path, tmp_path / "genome.json", path, expected=0, module="back")
    assert Partition.load(path, "worm") == Partition.preset("worm-halves", "worm")


# -- module files and assembly --------------------------------------------------------------------


@pytest.fixture()
def library(tmp_path, donor):
    """A library folder: the worm's front (3x2) and a one-voxel module ``dot``."""
    from somite.modules.library import export_module, provenance_of
    from somite.modules.module import cut

    folder = tmp_path / "lib"
    folder.mkdir()
    halves = Partition.preset("worm-halves", "worm")
    front = cut(donor, halves).module("front")
    export_module(front, folder / "front.json",
                  provenance_of(front, donor, halves.grid_string(), "donor.json", 1.5))
    dotted = Partition.from_grid("ABBBBB/BBBBBB", "worm")
    dot = cut(donor, dotted).module("A")
    export_module(dot, folder / "dot.json",
                  provenance_of(dot, donor, dotted.grid_string(), "donor.json", None))
    return folder


def _edit_module(path, change, literal: str | None = None) -> None:
    data = json.loads(path.read_text())
    change(data)
    text = json.dumps(data)
    path.write_text(text if literal is None else text.replace('"@"', literal))


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity", "1e999", "1" + "0" * 400])
def test_a_non_finite_donor_velocity_is_refused(capsys, library, literal):
    front = library / "front.json"
    _edit_module(front, lambda d: d["provenance"].update(donor_velocity="@"), literal)
    err = cli(capsys, "module", "list", library)
    assert err.startswith(f"somite module: error: module={str(front)!r}: "
                          "provenance.donor_velocity=")
    assert err.endswith(": must be a finite number or null\n")


@pytest.mark.parametrize("key, value", [
    ("donor_velocity", "1.5"), ("donor_velocity", True), ("origin", ["3", 0]),
    ("origin", [3.0, 0]), ("origin", None), ("donor", 7), ("donor_shape", 111111),
    ("partition", ["AAABBB"]), ("module", None),
])
def test_module_provenance_is_read_strictly(capsys, library, key, value):
    front = library / "front.json"
    _edit_module(front, lambda d: d["provenance"].update({key: value}))
    err = cli(capsys, "module", "list", library)
    assert err.startswith(f"somite module: error: module={str(front)!r}: "
                          f"provenance.{key}={value!r}: ")


@pytest.mark.parametrize("change, field", [
    (lambda d: d.update(label=5), "label=5"),
    (lambda d: d["voxels"][0].update(x=0.0), "voxels[0]=(0.0, 0)"),
    (lambda d: d["voxels"][0].update(sensors=["area", "area"]), "sensors=('area', 'area')"),
    (lambda d: d["nodes"][0].update(id=True), "nodes[0].id=True"),
])
def test_module_contents_are_read_strictly(capsys, library, change, field):
    front = library / "front.json"
    _edit_module(front, change)
    err = cli(capsys, "module", "list", library)
    assert err.startswith(f"somite module: error: module={str(front)!r}: {field}: ")


def test_a_module_wider_than_any_body_is_refused(capsys, tmp_path):
    from somite.evolution.operators import initial_genome
    from somite.modules.library import export_module, provenance_of
    from somite.modules.module import cut

    long = Body(Shape.from_cells([(x, 0) for x in range(MAX_SHAPE_SIDE + 1)]),
                tuple(("area",) for _ in range(MAX_SHAPE_SIDE + 1)))
    genome = initial_genome(long, np.random.default_rng(0))
    whole = Partition(long.shape, ("A",) * long.shape.n_voxels)
    module = cut(genome, whole).module("A")
    path = tmp_path / "long.json"
    export_module(module, path, provenance_of(module, genome, whole.grid_string()))
    err = cli(capsys, "module", "list", path)
    assert err == (f"somite module: error: module={str(path)!r}: voxels='33x1': a module spans "
                   "at most 32 voxels a side (somite.limits)\n")


@pytest.mark.parametrize("module, step, count, span", [
    ("front", 3, 12, "33x2"),  # the 36x2, refused at the module that passes 32
    ("dot", 1, 300, "33x1"),  # the 300x1
])
def test_assemble_refuses_a_body_over_the_side_limit(capsys, tmp_path, library, module, step,
                                                     count, span):
    places = [a for k in range(count) for a in ("--place", f"{module}@{k * step},0")]
    out = tmp_path / "assembled"
    first = next(k for k in range(count) if k * step + step > MAX_SHAPE_SIDE)
    err = cli(capsys, "assemble", library, *places, "--out", out)
    assert err == (f"somite assemble: error: place[{first}]='{module}@{first * step},0': the "
                   f"assembled body would span {span} voxels; at most 32 a side "
                   "(somite.limits)\n")
    assert not out.exists()


def test_assemble_still_builds_a_body_at_the_side_limit(capsys, tmp_path, library):
    places = [a for k in range(MAX_SHAPE_SIDE) for a in ("--place", f"dot@{k},0")]
    out = tmp_path / "assembled"
    text = cli(capsys, "assemble", library, *places, "--out", out, expected=0)
    assert "assembled " + "1" * MAX_SHAPE_SIDE in text
    assert Genome.load(out / "assembled.json").body.shape.width == MAX_SHAPE_SIDE


def test_a_valid_library_is_still_listed(capsys, library):
    out = cli(capsys, "module", "list", library, "--json", expected=0)
    listed = {item["name"]: item for item in json.loads(out)}
    assert listed["front"]["v_x"] == 1.5 and listed["dot"]["v_x"] is None
