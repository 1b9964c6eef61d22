"""Re-optimisation from a given genome, and rho over generations."""

from __future__ import annotations

import csv
import json

import numpy as np

from somite.brain.genome import Genome
from somite.cli import main
from somite.evolution.operators import initial_genome
from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.sim.body import Body
from somite.sim.config import SimConfig
from somite.tasks.validation import evaluate, validation_terrains


def _read(path):
    with open(path) as handle:
        return list(csv.DictReader(handle))


def test_starts_from_the_genome_and_its_mutants(tmp_path):
    body = Body.build("biped")
    start = initial_genome(body, np.random.default_rng(0))
    options = {"shape": "biped", "population": 6, "generations": 1, "duration": 2.0}
    state = evolve(resolve(options), tmp_path / "paper", start=start)
    log = _read(tmp_path / "paper" / "log.csv")
    assert int(log[0]["evaluations"]) == 6  # G' + 5 mutants
    assert len(state.population.genomes) == 6
    original = resolve({**options, "preset": "original-code"})
    evolve(original, tmp_path / "code", start=start)
    assert int(_read(tmp_path / "code" / "log.csv")[0]["evaluations"]) == 7  # G' + 6 mutants


def test_reoptimize_writes_rho_per_generation(tmp_path):
    body = Body.build("worm")
    donors = [initial_genome(body, np.random.default_rng(s)) for s in (1, 2)]
    paths = []
    for i, genome in enumerate(donors):
        paths.append(str(genome.save(tmp_path / f"donor{i}.json")))
    out = tmp_path / "reopt"
    code = main(["reoptimize", paths[0], "--donors", *paths, "--generations", "2",
                 "--population", "4", "--duration", "2", "--validation", "2", "--quiet",
                 "--out", str(out)])
    assert code == 0
    rows = _read(out / "transfer.csv")
    assert [int(r["generation"]) for r in rows] == [0, 1, 2]
    config = SimConfig(duration=2.0)
    terrains = validation_terrains(2)
    donors_mean = np.mean(np.nanmean(evaluate(donors, terrains, config), axis=1))
    first = json.loads((out / "bests.jsonl").read_text().splitlines()[0])
    best0 = Genome.from_dict(first["genome"])
    v0 = np.nanmean(evaluate([best0], terrains, config))
    assert float(rows[0]["rho"]) == float(v0 / donors_mean)
    saved = json.loads((out / "config.json").read_text())
    assert saved["start"] == paths[0] and saved["generations"] == 2
