"""Numbers with their caveat: p-values of tiny groups, tied discoveries, v_x over the whole
episode, and reports of a smoke-sized budget. Each says so where it applies, and only there.

Everything is built directly (run directories, a campaign folder with its validation cache
filled in), so that nothing evolves and nothing is simulated.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime

import numpy as np
import pytest
from scipy.stats import mannwhitneyu

from somite.analysis.stats import (
    MIN_GROUP_SIZE,
    PairTest,
    load_run,
    measures_whole_episode,
    small_sample_caveat,
    smallest_p,
)
from somite.brain.genome import Edge, Genome
from somite.cli import main
from somite.evolution.operators import initial_genome
from somite.experiments.config import resolve
from somite.experiments.logfile import LOG_COLUMNS, format_row
from somite.report.caveats import MIN_GENERATIONS
from somite.report.evolution import compare, one_sided
from somite.report.rerun import cache_key, write_cache
from somite.sim.body import Body
from somite.sim.config import SimConfig, whole_episode_warning
from somite.tasks.validation import validation_terrains

NOTE = f"n < {MIN_GROUP_SIZE} per group: not meaningful"

# -- Mann-Whitney p-values of tiny groups -----------------------------------------------------


def test_the_threshold_is_where_a_small_p_becomes_possible():
    # Fully separated samples give the smallest p the exact test has: 1/3 for 2 and 2 (one-
    # sided 1/6), which no difference can go below; 3 and 3 reach 0.1 (one-sided 0.05).
    assert mannwhitneyu([1, 2], [3, 4], alternative="less").pvalue == pytest.approx(1 / 6)
    assert smallest_p(2, 2) == pytest.approx(1 / 3) == mannwhitneyu([1, 2], [3, 4]).pvalue
    assert smallest_p(3, 3) == pytest.approx(0.1) == mannwhitneyu([1, 2, 3], [4, 5, 6]).pvalue
    assert small_sample_caveat(2, 2) == small_sample_caveat(1, 9) == NOTE
    assert small_sample_caveat(3, 3) is None and small_sample_caveat(3, 40) is None
    assert small_sample_caveat(0, 5) is None  # no p-value at all (NaN): nothing to qualify


def test_test_records_carry_the_caveat_only_for_small_groups():
    assert PairTest("a", "b", 2, 3, 6.0, 0.2).to_dict()["caveat"] == NOTE
    assert PairTest("a", "b", 3, 3, 9.0, 0.1).to_dict()["caveat"] is None
    small = compare({"x": [1.0, 2.0], "y": [3.0, 4.0, 5.0]})
    assert [t["caveat"] for t in small["tests"]] == [NOTE]
    assert one_sided(small, "y", "x")["caveat"] == NOTE
    enough = compare({"x": [1.0, 2.0, 2.5], "y": [3.0, 4.0, 5.0]})
    assert [t["caveat"] for t in enough["tests"]] == [None]
    assert one_sided(enough, "y", "x")["caveat"] is None


def fake_run(root, name, velocity, shape="worm", n_rows=3, **options):
    """A run directory as ``somite evolve`` writes it (config.json resolved, log.csv, best.json
    and bests.jsonl an initial genome), ending at ``velocity``; nothing simulated."""
    folder = root / name
    folder.mkdir(parents=True)
    config = resolve({"shape": shape, **options})
    (folder / "config.json").write_text(json.dumps(config.to_dict()))
    rows = [",".join(LOG_COLUMNS)]
    for g in range(n_rows):
        v = velocity * (g + 1) / n_rows
        row = {c: 0 for c in LOG_COLUMNS}
        row.update(generation=g, best_velocity=v, median_velocity=v / 2, worst_velocity=v / 4,
                   best_nodes=10, best_edges=20, best_size=30, median_size=30.0,
                   best_operator="add_edge", validation_velocity=None)
        rows.append(format_row(row))
    (folder / "log.csv").write_text("\n".join(rows) + "\n")
    body = Body.build(shape)
    best = initial_genome(body, np.random.default_rng(len(name)))
    best.save(folder / "best.json")
    (folder / "bests.jsonl").write_text("".join(
        json.dumps({"generation": g, "velocity": velocity * (g + 1) / n_rows,
                    "operator": "add_edge", "genome": json.loads(best.to_compact())}) + "\n"
        for g in range(n_rows)))
    return folder


def plot(tmp_path, capsys, sizes, **options):
    runs = [fake_run(tmp_path, f"{shape}{i}", 1.0 + i + 3 * k, shape, **options)
            for k, (shape, n) in enumerate(sizes.items()) for i in range(n)]
    out = tmp_path / "fig.png"
    assert main(["plot", *map(str, runs), "--out", str(out)]) == 0
    stats = json.loads((tmp_path / "fig.stats.json").read_text())
    return capsys.readouterr(), stats


def test_plot_warns_beside_the_p_value_of_groups_of_two(tmp_path, capsys):
    printed, stats = plot(tmp_path, capsys, {"biped": 2, "worm": 3})
    [warning] = printed.err.splitlines()
    assert warning == ("somite plot: warning: shape=biped vs shape=worm: p = 0.2 from 2 and 3 "
                       f"runs ({NOTE}; no data could give a p below 0.2 with so few)")
    assert "p = 0.2" in printed.out  # the number is kept
    [test] = stats["tests"]
    assert test["caveat"] == NOTE and test["p"] == pytest.approx(0.2)


def test_plot_of_groups_of_three_warns_of_nothing(tmp_path, capsys):
    printed, stats = plot(tmp_path, capsys, {"biped": 3, "worm": 3})
    assert printed.err == ""
    assert stats["tests"][0]["caveat"] is None and stats["whole_episode_runs"] == []


# -- v_x over the whole episode ---------------------------------------------------------------


def test_a_duration_within_the_transient_is_flagged_and_scored_as_before():
    short = SimConfig(duration=2.0, transient=5.0)
    assert short.measures_whole_episode and short.transient_steps == 0  # unchanged
    assert short.measured_interval == (0.0, 2.0)
    assert SimConfig(duration=5.0, transient=5.0).measures_whole_episode
    assert whole_episode_warning(short) == (
        "duration=2 s is not longer than transient=5 s: v_x is measured over the whole "
        "episode [0 s, 2 s], start-up included, not over [transient, duration]")
    for normal in (SimConfig(), SimConfig(duration=5.5, transient=5.0),
                   SimConfig(duration=2.0, transient=0.0)):
        assert not normal.measures_whole_episode and whole_episode_warning(normal) is None
    assert SimConfig().measured_interval == (5.0, 30.0)
    assert measures_whole_episode({"duration": 1.0, "transient": 5.0})
    assert not measures_whole_episode({"duration": 30.0, "transient": 5.0})
    assert not measures_whole_episode({"shape": "worm"})  # a config without the settings


def test_plot_names_runs_scored_over_the_whole_episode(tmp_path, capsys):
    printed, stats = plot(tmp_path, capsys, {"biped": 3, "worm": 3}, duration=2.0)
    [warning] = printed.err.splitlines()
    assert warning.startswith("somite plot: warning: 6 of 6 runs had a duration no longer "
                              "than their transient, so v_x is over the whole episode")
    assert len(stats["whole_episode_runs"]) == 6


# -- ties in module discovery -----------------------------------------------------------------


def block_genome() -> Genome:
    """Edges only inside the 2x2 block of the worm at x in {2, 3} (a ring, and one edge within
    each voxel): the block has c = 1, and so has every connected superset of it."""
    genome = initial_genome(Body.build("worm"), np.random.default_rng(0))
    genome = Genome(genome.body, genome.nodes, ())
    sensor = {(n.x, n.y): n.id for n in genome.nodes if n.kind == "sensor" and n.slot == 0}
    actuator = {(n.x, n.y): n.id for n in genome.nodes if n.kind == "actuator"}
    block = [(2, 0), (3, 0), (3, 1), (2, 1)]
    pairs = [(block[i], block[(i + 1) % 4]) for i in range(4)] + [(v, v) for v in block]
    edges = tuple(Edge(sensor[a], actuator[b], 0.5, 0.25) for a, b in pairs)
    return Genome(genome.body, genome.nodes, edges)


def discover(tmp_path, capsys, *extra):
    source = block_genome().save(tmp_path / "g.json")
    out = tmp_path / "out"
    assert main(["discover", str(source), "--out", str(out), *extra]) == 0
    return capsys.readouterr().out.splitlines(), json.loads((out / "partition.json").read_text())


def test_discover_says_when_candidates_tie_with_the_best(tmp_path, capsys):
    # b_max 5: the four 5-voxel supersets of the block tie with it at c = 1.
    lines, data = discover(tmp_path, capsys)
    assert lines[0] == ("most compact module (c = 1.000, tied with 4 other candidates; the "
                        "first in candidates.csv order is taken): [(2, 0), (3, 0), (2, 1), "
                        "(3, 1)]")
    assert data["tied_with_best"] == 4
    assert lines[2].endswith("(151 candidates: every connected set of b_min=2 to b_max=5 "
                             "voxels)")


def test_discover_without_a_tie_says_nothing_of_ties(tmp_path, capsys):
    lines, data = discover(tmp_path, capsys, "--max", "4")
    assert lines[0] == "most compact module (c = 1.000): [(2, 0), (3, 0), (2, 1), (3, 1)]"
    assert data["tied_with_best"] == 0
    assert lines[2].endswith(f"({16 + 28 + 43} candidates: every connected set of b_min=2 to "
                             "b_max=4 voxels)")


def test_discover_counts_candidates_for_the_largest_b_max_and_refuses_a_larger(tmp_path,
                                                                              capsys):
    lines, data = discover(tmp_path, capsys, "--max", "12")
    assert data["n_candidates"] == 669 and data["b_max"] == 12
    assert lines[2].endswith("(669 candidates: every connected set of b_min=2 to b_max=12 "
                             "voxels)")
    source = tmp_path / "g.json"
    assert main(["discover", str(source), "--out", str(tmp_path / "o"), "--max", "13"]) == 2
    assert capsys.readouterr().err == ("somite discover: error: b_max=13: the body has only 12 "
                                       "voxels\n")


# -- the report of a smoke-sized campaign -----------------------------------------------------


def fake_campaign(root, seeds, **options):
    """A campaign folder of finished rq1 and ablation evolve runs (biped and worm, ``seeds``
    each) with the report's validation cache already holding every re-run."""
    tasks, entries = [], {}
    names = [t.name for t in validation_terrains(2)]
    for experiment, offset in (("rq1", 1.0), ("ablation", 0.0)):
        for shape in ("biped", "worm"):
            for seed in range(seeds):
                task = f"{experiment}/{shape}-s{seed}"
                folder = fake_run(root, task, offset + 0.1 * seed, shape, seed=seed, **options)
                (folder / "done.json").write_text(json.dumps(
                    {"task": task, "finished": datetime.now(UTC).isoformat()}))
                tasks.append({"id": task, "experiment": experiment, "kind": "evolve",
                              "path": task, "needs": [],
                              "options": {"shape": shape, "seed": seed}})
                run = load_run(folder)
                genome = Genome.load(folder / "best.json")
                entries[cache_key(genome, resolve(run.config).setup.sim, names)] = [0.5, 0.25]
    experiments = {"rq1": {"title": "rq1"}, "ablation": {"title": "ablation"}}
    (root / "campaign.json").write_text(json.dumps(
        {"format": "somite-campaign", "version": 1, "name": "fake", "source": "test",
         "experiments": experiments, "tasks": tasks}))
    return entries


def report(tmp_path, capsys, seeds, **options):
    campaign = tmp_path / "campaign"
    entries = fake_campaign(campaign, seeds, **options)
    out = tmp_path / "report"
    write_cache(out / "cache" / "validation.json", entries)
    assert main(["report", str(campaign), "--out", str(out), "--validation", "2",
                 "--fresh", "0", "--no-timelapse", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert data["cache"]["genomes_simulated"] == 0
    return capsys.readouterr().err, (out / "index.md").read_text(), data


def test_smoke_budget_report_says_its_numbers_mean_nothing(tmp_path, capsys):
    err, text, data = report(tmp_path, capsys, 2, generations=2, population=4, duration=1.0)
    caveats = data["caveats"]
    assert caveats["budget"]["generations"]["max"] == 2
    assert caveats["budget"]["min_generations"] == MIN_GENERATIONS
    assert caveats["budget"]["caveat"].startswith("smoke-sized budget, these numbers mean "
                                                  "nothing: the evolve runs have at most 2 "
                                                  "generations of a population of 4")
    assert len(caveats["whole_episode"]["tasks"]) == 8
    assert caveats["small_groups"]["flagged"] == caveats["small_groups"]["tests"] > 0
    # At the top: right under the title, before the first section.
    head = text.split("## Tasks")[0]
    for caveat in caveats["banner"]:
        assert f"> **Warning:** {caveat}." in head
    assert len(caveats["banner"]) == 3
    assert f"({NOTE})" in text  # beside the p-values themselves
    test = data["figure5"]["comparison"]["worm"]["logged"]["tests"][0]
    assert test["caveat"] == NOTE and data["figure5"]["one_sided"]["worm"]["logged"]["caveat"]
    lines = err.splitlines()
    assert len(lines) == 3 and all(line.startswith("somite report: warning: ") for line in lines)
    assert "smoke-sized budget" in lines[0] and "whole episode" in lines[1]


def test_report_of_a_sufficient_budget_has_no_banner(tmp_path, capsys):
    err, text, data = report(tmp_path, capsys, 3, generations=150, population=32)
    caveats = data["caveats"]
    assert caveats["banner"] == [] and err == ""
    assert caveats["budget"]["caveat"] is None and caveats["whole_episode"]["tasks"] == []
    assert caveats["small_groups"]["flagged"] == 0 and caveats["small_groups"]["tests"] > 0
    assert "**Warning:**" not in text and f"({NOTE})" not in text
