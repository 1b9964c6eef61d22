"""The modularity workflows end to end, as a user runs them from the command line."""

from __future__ import annotations

import json

import numpy as np

from somite.brain.genome import Genome
from somite.cli import main
from somite.evolution.operators import add_edge, initial_genome
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.sim.partition import Partition
from somite.sim.terrain import parse_terrain
from somite.tasks.validation import evaluate


def donor(shape: str, seed: int, extra_edges: int = 12) -> Genome:
    rng = np.random.default_rng(seed)
    genome = initial_genome(Body.build(shape), rng)
    for _ in range(extra_edges):
        genome = add_edge(genome, rng)
    return genome


def test_heterogeneous_reassembly_simulates_and_reoptimises(tmp_path):
    biped = donor("biped", 1).save(tmp_path / "biped.json")
    worm = donor("worm", 2).save(tmp_path / "worm.json")
    out = tmp_path / "reassembled"
    take = ("left-leg=DONOR1:left-leg,right-leg=DONOR1:right-leg,torso=DONOR2:front")
    assert main(["reassemble", str(biped), str(worm), "--partition", "biped-legs",
                 "--partition", "worm-halves", "--receiver-shape", "biped", "--take", take,
                 "--validation", "2", "--duration", "3", "--out", str(out)]) == 0
    genome = Genome.load(out / "reassembled.json")
    assert genome.body.shape.grid_string() == "1111/1111/1001"
    report = json.loads((out / "report.json").read_text())
    assert "rho" in json.dumps(report)
    assert main(["reoptimize", str(out / "reassembled.json"), "--generations", "3",
                 "--population", "6", "--duration", "3", "--quiet",
                 "--out", str(tmp_path / "reopt")]) == 0
    log = (tmp_path / "reopt" / "log.csv").read_text().splitlines()
    assert len(log) == 1 + 4


def test_library_robot_improves_when_reoptimised(tmp_path):
    library = tmp_path / "library"
    library.mkdir()
    worm = donor("worm", 3).save(tmp_path / "worm.json")
    biped = donor("biped", 4).save(tmp_path / "biped.json")
    assert main(["module", "export", str(worm), "--partition", "worm-halves", "--module",
                 "back", "--out", str(library / "back.json")]) == 0
    assert main(["module", "export", str(biped), "--partition", "biped-legs", "--module",
                 "left-leg", "--out", str(library / "leg.json")]) == 0
    assert main(["assemble", str(library), "--place", "back@0,0", "--place", "leg@3,0",
                 "--out", str(tmp_path / "robot")]) == 0
    robot = Genome.load(tmp_path / "robot" / "assembled.json")
    assert robot.body.shape.n_voxels == 9
    # On one fixed terrain the best of a generation is not a lucky draw of terrains, so the
    # gain is the robot's own. Such slow robots can switch gaits with the sensor noise, so
    # both are measured over 16 noise seeds.
    assert main(["reoptimize", str(tmp_path / "robot" / "assembled.json"), "--generations",
                 "20", "--population", "16", "--duration", "10", "--seed", "3", "--quiet",
                 "--terrain", "flat", "--out", str(tmp_path / "reopt")]) == 0
    improved = Genome.load(tmp_path / "reopt" / "best.json")
    flat = [parse_terrain("flat")]
    velocities = np.array([evaluate([robot, improved], flat, SimConfig(duration=10.0), seed)[:, 0]
                           for seed in range(16)])
    before, after = velocities.mean(axis=0)
    assert after > before + 0.03  # 0.014 -> 0.064 m/s with this seed


def test_discovered_partition_is_read_by_every_command_that_takes_one(tmp_path, capsys):
    worm = donor("worm", 5, extra_edges=30).save(tmp_path / "worm.json")
    other = donor("worm", 6).save(tmp_path / "other.json")
    assert main(["discover", str(worm), "--out", str(tmp_path / "found")]) == 0
    path = tmp_path / "found" / "partition.json"
    found = Partition.load(path)
    assert found.shape.grid_string() == "111111/111111" and "A" in found.modules
    capsys.readouterr()

    assert main(["draw", str(worm), "--partition", str(path),
                 "--out", str(tmp_path / "brain.png")]) == 0
    assert f"cut by the {len(found.modules)} modules" in capsys.readouterr().out

    assert main(["module", "export", str(worm), "--partition", str(path), "--module", "A",
                 "--out", str(tmp_path / "library" / "A.json")]) == 0
    exported = json.loads((tmp_path / "library" / "A.json").read_text())
    assert exported["provenance"]["partition"] == found.grid_string()

    out = tmp_path / "reassembled"
    assert main(["reassemble", str(worm), str(other), "--partition", str(path),
                 "--validation", "0", "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["receiver"]["partition"] == found.grid_string()
    assert [m["module"] for m in report["modules"]] == list(found.modules)

    def evolve(partition, run):
        return ["evolve", "--shape", "worm", "--omega", "4", "--modules", str(partition),
                "--population", "4", "--generations", "1", "--duration", "1", "--quiet",
                "--out", str(tmp_path / run)]

    assert main(evolve(path, "run")) == 0
    # The file is read, not ignored: a partition discovered on another shape is refused.
    biped = donor("biped", 7).save(tmp_path / "biped.json")
    assert main(["discover", str(biped), "--out", str(tmp_path / "biped-found")]) == 0
    capsys.readouterr()
    wrong = str(tmp_path / "biped-found" / "partition.json")
    for command, field in ((evolve(wrong, "run2"), "modules"),
                           (["draw", str(worm), "--partition", wrong], "partition")):
        assert main(command) == 2
        err = capsys.readouterr().err.strip()
        assert f"error: {field}=" in err and "is for shape 1111/1111/1001" in err, err
    assert not (tmp_path / "run2").exists()
