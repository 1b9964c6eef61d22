"""The cuts during evolution (``somite.report.cut_curves``): which bests are read, that each
eta is the cut of that generation's best, and the groups compared at the same budget."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from somite.analysis.stats import RunLog
from somite.brain.genome import Edge, Genome
from somite.evolution.operators import initial_genome
from somite.modules.module import cut
from somite.report import markdown
from somite.report.cut_curves import KEY, cut_series, matched, partition_of, sampled_bests
from somite.sim.body import Body
from somite.sim.partition import Partition

from .test_report_sections import smoke_report


def _genome(shape: str, extra: int):
    """A minimal start of the shape with ``extra`` more edges, from the first sensor to the
    actuators furthest down the node list (other voxels: most of them in other modules), so
    that the generations' etas differ."""
    genome = initial_genome(Body.build(shape), np.random.default_rng(0))
    source = next(n for n in genome.nodes if n.kind == "sensor")
    targets = [n for n in reversed(genome.nodes)
               if n.kind == "actuator" and (n.x, n.y) != (source.x, source.y)]
    extra_edges = tuple(Edge(source.id, n.id, 0.5, 0.0) for n in targets[:extra])
    return Genome(genome.body, genome.nodes, genome.edges + extra_edges)


def _line(generation: int, genome) -> str:
    return json.dumps({"generation": generation, "velocity": 0.1 * generation,
                       "genome": genome.to_dict()}, separators=(",", ":")) + "\n"


def _write_run(folder: Path, shape: str, last: int, every: int, thinned=(), torn=None) -> None:
    """A run folder of ``last + 1`` generations: config.json, log.csv, bests.jsonl (lines of
    ``thinned`` generations thinned; with ``torn``, that generation's line cut short)."""
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(
        {"shape": shape, "modules": "paper", "validate_every": every}))
    rows = ["generation,best_velocity,best_size,validation_velocity"]
    lines = []
    for g in range(last + 1):
        validation = str(0.05 * g) if g % every == 0 else ""
        rows.append(f"{g},{0.1 * g},{10 + g},{validation}")
        line = _line(g, _genome(shape, g))
        if g in thinned:
            line = json.dumps({"generation": g, "thinned": "0123abcd"},
                              separators=(",", ":")) + "\n"
        if g == torn:
            line = line[:40]
        lines.append(line)
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    (folder / "bests.jsonl").write_text("".join(lines))


def _log(folder: Path) -> RunLog:
    """The run as the report holds it (only the columns the cuts read)."""
    import csv

    with open(folder / "log.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    log = {c: np.array([float(r[c]) if r[c] else np.nan for r in rows]) for c in rows[0]}
    return RunLog(folder, json.loads((folder / "config.json").read_text()), log)


def test_only_whole_genome_lines_of_the_sampled_generations_are_read(tmp_path):
    _write_run(tmp_path / "run", "worm", 9, 2, thinned=(4,), torn=9)
    bests = sampled_bests(tmp_path / "run" / "bests.jsonl", 2)
    assert sorted(bests) == [0, 2, 6, 8]  # 4 thinned, odd ones not due
    assert len(bests[6].edges) == len(_genome("worm", 6).edges)
    # the last generation when asked for, unless its line is still being written
    assert sorted(sampled_bests(tmp_path / "run" / "bests.jsonl", 2, last=9)) == [0, 2, 6, 8]
    assert sorted(sampled_bests(tmp_path / "run" / "bests.jsonl", 2, last=7)) == [0, 2, 6, 7, 8]
    assert sampled_bests(tmp_path / "nothing.jsonl", 2) == {}


def test_each_eta_is_the_cut_of_that_generations_best(tmp_path):
    _write_run(tmp_path / "run", "biped", 7, 3)
    # under way: to its last sampled generation; finished: to its last
    assert cut_series(_log(tmp_path / "run"), finished=False).log["generation"].tolist() == [
        0, 3, 6]
    series = cut_series(_log(tmp_path / "run"))
    assert series.log["generation"].tolist() == [0, 3, 6, 7]
    partition = Partition.preset("paper", "biped")
    for k, g in enumerate((0, 3, 6)):
        total = cut(_genome("biped", g), partition).total
        assert series.log["eta_num"][k] == total.eta_num
        assert series.log["eta_weight"][k] == total.eta_weight
        assert series.log["best_size"][k] == 10 + g
        assert series.log["validation_velocity"][k] == 0.05 * g
    # the minimal start cuts nothing (its edges stay in their voxels); the added edges do
    assert series.log["eta_num"][0] == 0 < series.log["eta_num"][2]


def test_a_run_without_partition_or_samples_has_no_series(tmp_path):
    _write_run(tmp_path / "run", "worm", 2, 1)
    run = _log(tmp_path / "run")
    assert partition_of(run) is not None
    odd = RunLog(run.path, {**run.config, "shape": "3x3"}, run.log)  # no paper partition
    assert partition_of(odd) is None and cut_series(odd) is None
    assert cut_series(RunLog(run.path, {**run.config, "validate_every": 0}, run.log)) is None
    (tmp_path / "run" / "bests.jsonl").write_text("")
    assert cut_series(run) is None


def _series(last: int, eta: float, every: int = 50) -> RunLog:
    generation = np.arange(0, last + 1, every, dtype=float)
    values = eta + generation / 10000
    return RunLog(Path("."), {}, {"generation": generation, "eta_num": values,
                                  "eta_weight": values / 2, "best_size": generation + 80,
                                  "best_velocity": generation / 1000,
                                  "validation_velocity": generation / 2000})


def test_the_groups_are_compared_where_all_of_them_reached():
    """Omega 1 finished (3000), omega 10 under way at 1110 (sampled to 1100): the groups at
    1100; the same once omega 10 is past every finished run is the final comparison's."""
    found = {"biped": {"omega 1": {"rq1/biped-s0": _series(3000, 0.5),
                                   "rq1/biped-s1": _series(3000, 0.3)},
                       "omega 10": {"omega-10/biped-s0": _series(1110, 0.1)}},
             "worm": {"omega 1": {"rq1/worm-s0": _series(3000, 0.4)}}}
    out = matched(found, {"omega-10/biped-s0"})
    assert list(out) == ["biped"] and out["biped"]["generation"] == 1100
    modular = out["biped"]["groups"]["omega 10"]
    assert modular["runs"] == modular["under_way"] == ["omega-10/biped-s0"]
    assert math.isclose(modular["eta_num"], 0.1 + 0.11)
    neutral = out["biped"]["groups"]["omega 1"]
    assert neutral["under_way"] == [] and math.isclose(neutral["eta_num"], 0.4 + 0.11)
    assert (neutral["best_size"], neutral["best_velocity"]) == (1180.0, 1.1)
    assert matched(found, set()) == {}  # every compared run finished
    found["biped"]["omega 10"] = {"omega-10/biped-s0": _series(40, 0.1)}
    assert matched(found, {"omega-10/biped-s0"}) == {}  # nothing past generation 0
    # Rendered with the runs under way named.
    report = smoke_report()
    found["biped"]["omega 10"] = {"omega-10/biped-s0": _series(1110, 0.1)}
    report[KEY] = {"every": {"rq1/biped-s0": 50}, "curves": {}, "without": ["odd/3x3-s0"],
                   "under_way": {"omega-10/biped-s0": 1100},
                   "matched": matched(found, {"omega-10/biped-s0"}), "final": {},
                   "files": []}
    text = markdown.render_markdown(report).split("## Beyond the paper: eta of the best")[1]
    assert "| biped | 1100 | omega 10 | 1 | omega-10/biped-s0 | 0.210 | 0.105 | 1180.0 | " \
           "1.100 | 0.550 |" in text
    assert "omega-10/biped-s0 (generation 1100)" in text and "odd/3x3-s0" in text
    assert "every 50 generations" in text
