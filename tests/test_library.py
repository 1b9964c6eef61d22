"""The module library: module files, listing, assembling robots, and their commands."""

import json
import math

import pytest

from somite.brain.genome import Genome
from somite.cli import main
from somite.modules.library import (
    Placement,
    assemble,
    export_module,
    list_library,
    load_module,
    module_to_dict,
    parse_placement,
    provenance_of,
)
from somite.modules.module import cut
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.partition import Partition
from somite.tasks.validation import evaluate, validation_terrains

from .conftest import evolved, expect_error


@pytest.fixture(scope="module")
def donors():
    return {"biped": evolved("biped", 71), "worm": evolved("worm", 72)}


@pytest.fixture(scope="module")
def library(donors, tmp_path_factory):
    """A folder with the biped's left leg (velocity known) and the worm's back and front."""
    folder = tmp_path_factory.mktemp("library")
    legs = Partition.preset("biped-legs", "biped")
    halves = Partition.preset("worm-halves", "worm")
    for name, donor, partition, label, velocity in (
        ("leg", donors["biped"], legs, "left-leg", 1.25),
        ("back", donors["worm"], halves, "back", None),
        ("front", donors["worm"], halves, "front", None),
    ):
        module = cut(donor, partition).module(label)
        provenance = provenance_of(module, donor, partition.grid_string(), f"{name}.src", velocity)
        export_module(module, folder / f"{name}.json", provenance)
    return folder


# -- files ----------------------------------------------------------------------------------------


def test_module_file_round_trip(donors, library):
    front = cut(donors["worm"], Partition.preset("worm-halves", "worm")).module("front")
    item = load_module(library / "front.json")
    assert item.name == "front" and item.module.label == "front"
    # Coordinates relative to the module's corner; ids, sensors, edges unchanged.
    assert item.module.voxels == tuple((x - 3, y) for x, y in front.voxels)
    assert item.module.sensors == front.sensors
    assert item.module.nodes == front.relative().nodes
    assert item.module.edges == front.edges
    assert item.provenance.origin == (3, 0)
    assert item.provenance.donor_shape == "111111/111111"
    assert item.provenance.partition == "AAABBB/AAABBB"
    data = json.loads((library / "front.json").read_text())
    assert (data["format"], data["version"]) == ("somite-module", 1)
    assert data["voxels"][0] == {"x": 0, "y": 0, "sensors": ["area", "touch"]}


def test_list_library(library):
    items = list_library(library)
    assert [i.name for i in items] == ["back", "front", "leg"]
    summary = {i.name: i.summary() for i in items}
    assert summary["leg"]["size"] == 3 and summary["leg"]["v_x"] == 1.25
    assert summary["leg"]["sensors"] == {"area": 3, "touch": 1, "velocity": 1}
    assert summary["front"]["sensors"] == {"area": 6, "touch": 3, "velocity": 3, "lidar": 2}
    assert summary["back"]["donor"] == "back.src" and summary["back"]["v_x"] is None


@pytest.mark.parametrize(
    "change, words",
    [({"version": 2}, "version=2"), ({"format": "somite-genome"}, "format='somite-genome'")],
    ids=["version", "format"],
)
def test_unknown_module_file_is_a_one_line_error(library, tmp_path, change, words):
    data = json.loads((library / "leg.json").read_text())
    data.update(change)
    path = tmp_path / "odd.json"
    path.write_text(json.dumps(data))
    message = expect_error("module", lambda: load_module(path))
    assert words in message
    expect_error("module", lambda: list_library(tmp_path))


def test_broken_module_file_is_refused(library, tmp_path):
    data = json.loads((library / "leg.json").read_text())
    data["nodes"] = [n for n in data["nodes"] if n["kind"] != "actuator"]
    data["edges"] = [e for e in data["edges"] if e["dst"] in {n["id"] for n in data["nodes"]}]
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(data))
    message = expect_error("module", lambda: load_module(path))
    assert "no actuator node" in message


# -- assembly -------------------------------------------------------------------------------------


def test_assemble_from_two_donors(library, donors):
    items = {i.name: i for i in list_library(library)}
    # The biped's left leg (a 1x3 column) at the left, the worm's back (3x2) beside its foot.
    genome = assemble([Placement(items["leg"], 0, 0), Placement(items["back"], 1, 0)])
    assert genome.body.shape.grid_string() == "1000/1111/1111"
    sensors = dict(zip(genome.body.shape.voxels, genome.body.sensors))
    assert sensors[(0, 2)] == ("area", "velocity")  # the leg's top voxel
    assert sensors[(1, 1)] == ("area", "velocity")  # the worm back's (0, 1)
    assert sensors[(3, 0)] == ("area", "touch")
    leg, back = items["leg"].module, items["back"].module
    assert genome.n_edges == len(leg.edges) + len(back.edges)
    hidden = [n for n in genome.nodes if n.kind == "hidden"]
    assert len(hidden) <= sum(n.kind == "hidden" for n in leg.nodes + back.nodes)
    # Every weight comes along, no edge joins the two modules.
    assert sorted(e.weight for e in genome.edges) == sorted(
        e.weight for e in leg.edges + back.edges
    )
    nodes = {n.id: n for n in genome.nodes}
    assert not [e for e in genome.edges if (nodes[e.src].x == 0) != (nodes[e.dst].x == 0)]
    velocity = evaluate([genome], validation_terrains(1), SimConfig(duration=2.0))
    assert math.isfinite(velocity[0, 0])


def test_assemble_moves_everything_to_a_zero_corner(library):
    items = {i.name: i for i in list_library(library)}
    genome = assemble([Placement(items["front"], 5, 7), Placement(items["back"], 2, 7)])
    # The worm rebuilt from its own halves, placed far from the origin.
    assert genome.body.shape.grid_string() == "111111/111111"
    assert genome.body == Body.build("worm")


def test_bad_placements(library):
    items = list_library(library)
    by_name = {i.name: i for i in items}
    overlap = [Placement(by_name["leg"], 0, 0), Placement(by_name["back"], 0, 1)]
    message = expect_error("place[1]", lambda: assemble(overlap))
    assert "overlaps place[0]" in message and "(0, 1)" in message
    apart = [Placement(by_name["leg"], 0, 0), Placement(by_name["back"], 2, 0)]
    assert "4-connected" in expect_error("place[1]", lambda: assemble(apart))
    diagonal = [Placement(by_name["back"], 0, 0), Placement(by_name["leg"], 3, 2)]
    expect_error("place[1]", lambda: assemble(diagonal))
    expect_error("place", lambda: assemble([]))
    expect_error("place", lambda: parse_placement("leg0,0", items))
    expect_error("place", lambda: parse_placement("arm@0,0", items))
    assert parse_placement("leg@-1,2", items).text == "leg@-1,2"


# -- commands -------------------------------------------------------------------------------------


def test_module_export_and_list_commands(tmp_path, donors, capsys):
    source = donors["worm"].save(tmp_path / "worm.json")
    folder = tmp_path / "lib"
    assert main([
        "module", "export", str(source), "--partition", "AAABBB/AAABBB", "--module", "B",
        "--out", str(folder / "front.json"), "--velocity", "2.5",
    ]) == 0
    item = load_module(folder / "front.json")
    assert item.provenance.donor_velocity == 2.5 and item.module.size == 6
    capsys.readouterr()
    assert main(["module", "list", str(folder), "--json"]) == 0
    [summary] = json.loads(capsys.readouterr().out)
    assert (summary["name"], summary["size"], summary["v_x"]) == ("front", 6, 2.5)
    assert main(["module", "list", str(folder)]) == 0
    assert "front" in capsys.readouterr().out


@pytest.mark.parametrize(
    "extra, field",
    [
        (["--partition", "AAAA/BBBB", "--module", "A"], "partition"),  # not the worm's grid
        (["--partition", "worm-halves", "--module", "torso"], "module"),
        (["--partition", "AAABBB/ABABBB", "--module", "A"], "partition"),  # A not connected
    ],
    ids=["not-covering", "no-such-module", "disconnected-module"],
)
def test_module_export_bad_input_writes_nothing(tmp_path, donors, capsys, extra, field):
    source = donors["worm"].save(tmp_path / "worm.json")
    out = tmp_path / "lib" / "m.json"
    assert main(["module", "export", str(source), *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"somite module: error: {field}=") and "\n" not in err
    assert not out.parent.exists()


def test_module_list_of_unknown_version_fails(tmp_path, library, capsys):
    folder = tmp_path / "lib"
    folder.mkdir()
    data = json.loads((library / "leg.json").read_text())
    data["version"] = 99
    (folder / "leg.json").write_text(json.dumps(data))
    assert main(["module", "list", str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert "version=99" in err and "\n" not in err


def test_assemble_command(tmp_path, library, capsys):
    out = tmp_path / "robot"
    assert main([
        "assemble", str(library), "--place", "leg@0,0", "--place", "back@1,0", "--out", str(out),
        "--evaluate", "1", "--duration", "2",
    ]) == 0
    genome = Genome.load(out / "assembled.json")
    assert genome.body.shape.grid_string() == "1000/1111/1111"
    evaluation = json.loads((out / "evaluation.json").read_text())
    assert len(evaluation["per_terrain"]) == 1 and math.isfinite(evaluation["v_x"])


@pytest.mark.parametrize(
    "places, field",
    [
        (["leg@0,0", "back@0,1"], "place[1]"),  # overlap
        (["leg@0,0", "back@2,0"], "place[1]"),  # disconnected
        (["leg@0,0", "wing@1,0"], "place[1]"),  # unknown name
    ],
    ids=["overlap", "disconnected", "unknown"],
)
def test_assemble_command_bad_placements_write_nothing(tmp_path, library, capsys, places, field):
    out = tmp_path / "robot"
    args = ["assemble", str(library), "--out", str(out)]
    for place in places:
        args += ["--place", place]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"somite assemble: error: {field}=") and "\n" not in err
    assert not out.exists()


def test_module_dict_is_strict_json(donors):
    module = cut(donors["biped"], Partition.preset("biped-legs", "biped")).module("torso")
    provenance = provenance_of(module, donors["biped"], "ACCB/ACCB/A..B")
    data = module_to_dict(module, provenance)
    text = json.dumps(data, allow_nan=False)
    assert json.loads(text)["provenance"]["origin"] == [1, 1]
    expect_error(
        "velocity",
        lambda: provenance_of(module, donors["biped"], "x", None, float("nan")),
    )
