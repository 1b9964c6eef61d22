"""``somite report`` on a tiny campaign directory: every section, numbers that agree with the
run directories, missing tasks shown as missing, the cache, and bad input."""

from __future__ import annotations

import csv
import json
import shutil

import numpy as np
import pytest
from scipy.stats import mannwhitneyu

from somite.analysis.stats import load_run
from somite.brain.genome import Genome
from somite.cli import main
from somite.experiments.config import resolve
from somite.report.build import logged_over_validation
from somite.report.rerun import FRESH_COUNT
from somite.report.text import number
from somite.tasks.validation import evaluate, fresh_terrains
from somite.tasks.velocity import mean_velocity

from .campaign_fixture import UNFINISHED, build_campaign
from .test_report_sections import skeleton, smoke_report

SECTIONS = ("## Tasks", "## Table 1", "## Figure 3", "## Figure 10", "## Figure 5",
            "## Figure 11", "## Beyond the paper: eta of the best during evolution",
            "### Figure 7", "### Figure 8", "## Figure 9", "## Figure 12",
            "## Beyond the paper: reassembly along the discovered modules",
            "## Beyond the paper: every final best on the validation terrains",
            "## Transfer: the final bests in 2D-VSR-Sim", "## Time-lapse")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    return build_campaign(tmp_path_factory.mktemp("campaign"))


@pytest.fixture(scope="module")
def report(campaign, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    return out, json.loads((out / "report.json").read_text())


def _log(folder) -> list[dict]:
    with open(folder / "log.csv", newline="") as handle:
        return list(csv.DictReader(handle))


def _finished(campaign, experiment, prefix):
    """The finished task folders of ``experiment`` whose names start with ``prefix``."""
    return sorted(p for p in (campaign / experiment).iterdir()
                  if p.name.startswith(prefix) and (p / "done.json").is_file())


def check_sections(out, data) -> None:
    """Every section in index.md, every figure listed written (PNG and SVG) and linked."""
    text = (out / "index.md").read_text()
    for heading in SECTIONS:
        assert heading in text, heading
    assert (out / "index.html").read_text().count("<table>") >= 8
    listed = [*data["figure3"]["files"], *data["figure10"]["files"],
              *data["figure5"]["files"]["logged"], *data["figure11"]["files"]["validation"],
              *data["figure7"]["files"], *data["figure8"]["files"],
              *data["figure9"]["files"]["eta_num"], *data["discovery"]["files"],
              *data["rq3_reassembly"]["files"], *data["validation"]["files"],
              *data["cuts_during_evolution"]["files"]]
    assert {name.rsplit(".", 1)[1] for name in listed} == {"png", "svg"}
    for name in listed:
        assert (out / "figures" / name).stat().st_size > 0
        assert f"figures/{name}" in text


def check_table1(campaign, data) -> None:
    """Table 1's medians are those of the finished runs' log.csv rows."""
    rows = {(r["experiment"], r["shape"]): r for r in data["table1"]}
    for experiment in ("rq1", "ablation", "omega-10", "omega-0.1"):
        for shape in ("biped", "worm"):
            logs = [_log(f) for f in _finished(campaign, experiment, shape)]
            row = rows[experiment, shape]
            assert row["n"] == len(logs) > 0
            last = [float(log[-1]["best_velocity"]) for log in logs]
            assert row["final"]["velocity"]["median"] == float(np.median(last))
            assert row["final"]["size"]["median"] == float(
                np.median([float(log[-1]["best_size"]) for log in logs]))
            assert row["initial"]["nodes"]["median"] == float(
                np.median([float(log[0]["best_nodes"]) for log in logs]))
    assert rows["rq1", "worm"]["paper"]["final"]["size"]["value"] == 216.0
    assert rows["ablation", "worm"]["paper"] is None


def check_p_values(campaign, data) -> None:
    """Figure 5's p-values are scipy's on the logs' last rows."""
    for shape in ("biped", "worm"):
        finals = {e: [float(_log(f)[-1]["best_velocity"]) for f in _finished(campaign, e, shape)]
                  for e in ("rq1", "ablation")}
        [test] = data["figure5"]["comparison"][shape]["logged"]["tests"]
        expected = mannwhitneyu(finals["rq1"], finals["ablation"], alternative="two-sided")
        assert (test["u"], test["p"]) == (float(expected.statistic), float(expected.pvalue))
        paper_test = data["figure5"]["one_sided"][shape]["logged"]
        expected = mannwhitneyu(finals["rq1"], finals["ablation"], alternative="greater")
        assert paper_test["p"] == float(expected.pvalue)


def check_validation(campaign, data, terrains: int) -> None:
    """The re-run of each rq1 best is the run's own validation of its last generation."""
    robots = {r["task"]: r for r in data["validation"]["robots"]}
    for folder in _finished(campaign, "rq1", ""):
        last = _log(folder)[-1]
        robot = robots[f"rq1/{folder.name}"]
        assert robot["logged"] == float(last["best_velocity"])
        assert robot["validation"] == float(last["validation_velocity"])
        assert robot["validation"] == float(np.mean(robot["velocities"]))
        assert len(robot["velocities"]) == terrains
    assert any(r["task"].endswith("-reopt") for r in robots.values())


def test_every_section_and_figure_is_written(report):
    out, data = report
    check_sections(out, data)
    strips = {(s["experiment"], s["shape"]) for s in data["timelapse"]}
    assert ("rq1", "biped") in strips and ("rq2-homo", "worm") in strips
    for strip in data["timelapse"]:
        assert (out / "figures" / strip["file"]).is_file()
        page = (out / "figures" / strip["replay"]).read_text()
        assert page.startswith("<!doctype html>") and strip["task"] in page
        assert strip["gait"] and f"Gait: {strip['gait']}." in (out / "index.md").read_text()


def test_figure3_stands_beside_the_papers_numbers(campaign, report):
    """Figure 3's curves at both ends, the paper's v_x (section 5.1) and |G| (Table 1) below;
    the transfer section waits for its transfer.csv."""
    out, data = report
    text = (out / "index.md").read_text()
    assert data["figure3"]["paper"]["size"]["worm"]["final"]["value"] == 216.0
    assert "| paper |  | 10 | 3000 | ≈ 0.5 | ≈ 5 | not measured | 92 | 216 ± 39.4 |" in text
    worm = data["figure3"]["curves"]["worm"]["omega 1"]
    logs = [_log(f) for f in _finished(campaign, "rq1", "worm")]
    assert worm["velocity_median"][-1] == float(np.median(
        [float(log[-1]["best_velocity"]) for log in logs]))
    row = (f"| worm | omega 1 | {len(logs)} | 2 | {worm['velocity_median'][0]:.3f} | "
           f"{worm['velocity_median'][-1]:.3f} |")
    assert row in text
    assert not data["transfer"]["present"] and "Not measured yet" in text


def test_table1_final_velocity_is_the_median_of_the_logs_last_rows(campaign, report):
    check_table1(campaign, report[1])


def test_p_values_are_scipys_on_the_final_velocities(campaign, report):
    _, data = report
    check_p_values(campaign, data)
    tests = data["figure11"]["comparison"]["worm"]["logged"]["tests"]
    assert len(tests) == 3  # omega 0.1, 1 and 10, pairwise


def test_validation_reruns_agree_with_the_runs_own_validation(campaign, report):
    check_validation(campaign, report[1], 10)


def test_rho_and_eta_are_those_of_the_task_folders(campaign, report):
    _, data = report
    for shape in ("biped", "worm"):
        folders = _finished(campaign, "rq2-homo", shape)
        ends = [float(_rows(f / "transfer.csv")[-1]["rho"]) for f in folders
                if f.name.endswith("-reopt")]
        group = data["figure7"]["curves"][shape]["homogeneous"]
        assert sorted(group["end"]) == sorted(ends)
        assert group["median"][-1] == float(np.median(ends))
        etas = [json.loads((f / "report.json").read_text())["pooled"]["eta_num"]
                for f in folders if not f.name.endswith("-reopt")]
        groups = data["figure9"]["eta"][shape]["eta_num"]["groups"]
        assert sorted(groups["omega 1"]["values"]) == sorted(etas)
        assert set(groups) == {"omega 0.1", "omega 1", "omega 10"}
    assert set(data["figure7"]["curves"]["worm"]) == {"homogeneous", "heterogeneous"}
    for shape in ("biped", "worm"):
        # The fixture reassembles rq1's s0+s1 along the discovered modules: beside it, of
        # Figure 7's three homogeneous pairs, the one with the same donors.
        groups = data["rq3_reassembly"]["curves"][shape]
        assert set(groups) == {"discovered modules", "paper partition, same donors"}
        assert groups["discovered modules"]["tasks"] == [f"rq3-reassembly/{shape}-s0+s1-reopt"]
        beside = groups["paper partition, same donors"]
        assert beside["tasks"] == [f"rq2-homo/{shape}-s0+s1-reopt"]
        homogeneous = data["figure7"]["curves"][shape]["homogeneous"]
        same = homogeneous["tasks"].index(beside["tasks"][0])
        assert beside["end"] == [homogeneous["end"][same]]
        assert len(data["rq3_reassembly"]["end"][shape]["tests"]) == 1


def test_the_cuts_during_evolution_are_those_of_each_runs_bests(campaign, report):
    """Every finished run of Figure 10's groups, cut along the paper's partition at each
    generation (validate_every 1): its last eta is the cut of its last best, and the groups'
    final etas are compared as Figure 9's are."""
    from somite.modules.module import cut
    from somite.sim.partition import Partition

    _, data = report
    cuts = data["cuts_during_evolution"]
    assert cuts["under_way"] == {} and cuts["matched"] == {} and cuts["without"] == []
    for shape in ("biped", "worm"):
        partition = Partition.preset("paper", shape)
        compared = cuts["final"][shape]["eta_num"]
        assert len(compared["groups"]) == 3 and len(compared["tests"]) == 3
        finished = {f"{e}/{f.name}" for e in ("rq1", "omega-10", "omega-0.1")
                    for f in _finished(campaign, e, shape)}
        assert {t for g in compared["groups"].values() for t in g["tasks"]} == finished
        for label, group in compared["groups"].items():
            expected = []
            for task in group["tasks"]:
                last = (campaign / task / "bests.jsonl").read_text().splitlines()[-1]
                best = Genome.from_dict(json.loads(last)["genome"])
                expected.append(cut(best, partition).total.eta_num)
            assert group["values"] == expected
            assert cuts["curves"][shape][label]["generation"] == [0.0, 1.0, 2.0]
            assert cuts["curves"][shape][label]["eta_num_median"][0] == 0.0  # minimal start


def test_figure7_sets_what_the_paper_says_beside_each_group(report):
    out, _ = report
    rows = [line for line in (out / "index.md").read_text().splitlines()
            if line.startswith(("| biped | heterogeneous |", "| worm | homogeneous |"))]
    assert len(rows) == 2
    assert rows[0].endswith("more challenging heterogeneous combinations\" (no number) |")
    assert rows[1].endswith("≈ 0.8: worms just fall short of 80 % |")


def test_discovery_rows_are_the_partition_files(campaign, report):
    _, data = report
    robots = data["discovery"]["robots"]
    assert len(robots) == 6
    for robot in robots:
        saved = json.loads((campaign / robot["task"] / "partition.json").read_text())
        assert robot["grid"] == saved["grid"]
        assert robot["compactness"] == saved["best"]["compactness"]


def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_unfinished_tasks_are_missing_not_counted(report):
    out, data = report
    status = data["status"]["experiments"]
    assert status["rq1"]["missing"] == [UNFINISHED[0]]
    assert status["ablation"]["missing"] == [UNFINISHED[1]]
    row = next(r for r in data["table1"] if (r["experiment"], r["shape"]) == ("rq1", "worm"))
    assert (row["n"], row["tasks"], row["missing"]) == (3, 4, [UNFINISHED[0]])
    assert UNFINISHED[0] not in {r["task"] for r in data["validation"]["robots"]}
    assert UNFINISHED[0] in (out / "index.md").read_text()


def test_a_second_report_simulates_nothing_and_says_the_same(campaign, report):
    out, first = report
    assert first["cache"]["genomes_simulated"] > 0
    figures = {p.name: p.read_bytes() for p in (out / "figures").glob("*.svg")}
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    second = json.loads((out / "report.json").read_text())
    assert second["cache"] == {"genomes_simulated": 0, "strips_drawn": 0}
    # the same numbers draw the same figures, byte for byte (no date, no random ids)
    assert figures and figures == {p.name: p.read_bytes()
                                   for p in (out / "figures").glob("*.svg")}
    assert {k: v for k, v in second.items() if k != "cache"} == {
        k: v for k, v in first.items() if k != "cache"}
    # A damaged cache entry is simulated again, and gives the same numbers.
    cache = out / "cache" / "validation.json"
    saved = json.loads(cache.read_text())
    key = next(iter(saved["entries"]))
    saved["entries"][key] = [0.0]
    cache.write_text(json.dumps(saved))
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    third = json.loads((out / "report.json").read_text())
    assert third["cache"] == {"genomes_simulated": 1, "strips_drawn": 0}
    assert third["validation"] == first["validation"]
    # A gait line written by other rules of the gait summary (an older somite) is drawn again.
    strips = out / "cache" / "timelapse.json"
    saved = json.loads(strips.read_text())
    stale = next(k for k in saved["entries"] if k.endswith(".gait"))
    saved["entries"][stale] = {**saved["entries"][stale], "rules": "older"}
    strips.write_text(json.dumps(saved))
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    fourth = json.loads((out / "report.json").read_text())
    assert fourth["cache"] == {"genomes_simulated": 0, "strips_drawn": 1}
    assert fourth["timelapse"] == first["timelapse"]


def test_every_final_best_is_re_run_on_fresh_terrains_under_fresh_noise(campaign, report):
    """Beside the validation re-run, each final best's v_x on the fresh terrains (neither
    training nor validation terrains) at noise seed 1: the numbers of ``evaluate`` there."""
    out, data = report
    robots = data["validation"]["robots"]
    names = [t.name for t in fresh_terrains(FRESH_COUNT)]
    assert names[0] == "hilly-1-10-20000" and len(names) == FRESH_COUNT == 20
    assert robots and all(r["fresh_terrains"] == names for r in robots)
    assert not set(names) & set(robots[0]["terrains"])
    robot = robots[0]
    folder = campaign / robot["task"]
    sim = resolve(load_run(folder).config).setup.sim
    velocities = evaluate([Genome.load(folder / "best.json")], fresh_terrains(20), sim, seed=1)
    assert robot["fresh_velocities"] == velocities[0].tolist()
    assert robot["fresh"] == mean_velocity(velocities[0]) and robot["fresh_noise_seed"] == 1
    # not the validation episodes under another name: other terrains, other noise
    assert robot["fresh_velocities"][:10] != robot["velocities"]
    group = next(g for g in data["validation"]["summary"]
                 if (g["experiment"], g["shape"]) == (robot["experiment"], robot["shape"]))
    members = [r["fresh"] for r in robots
               if (r["experiment"], r["shape"]) == (robot["experiment"], robot["shape"])]
    assert group["fresh"]["median"] == float(np.median(members))
    text = (out / "index.md").read_text()
    assert "And on 20 fresh terrains (hilly-1-10-20000 on" in text
    assert (f"| {robot['task']} | {robot['logged']:.3f} | {robot['validation']:.3f} | "
            f"{robot['logged_validation']:.3f} | {robot['fresh']:.3f} | "
            f"{number(robot['logged_over_validation'], 2)} |") in text
    assert all(r["logged_over_validation"] == logged_over_validation(r["logged"], r["validation"])
               for r in robots)


def test_logged_over_validation_is_none_where_validation_measures_nothing():
    assert logged_over_validation(3.0, 2.0) == 1.5
    assert logged_over_validation(-0.5, 0.25) == -2.0
    for validation in (0.0, -0.1, float("nan"), float("inf")):
        assert logged_over_validation(1.0, validation) is None, validation
    assert logged_over_validation(float("nan"), 1.0) is None


def test_fresh_0_re_runs_on_no_fresh_terrain_and_a_bad_count_is_named(campaign, tmp_path,
                                                                     capsys):
    out = tmp_path / "report"
    assert main(["report", str(campaign), "--out", str(out), "--fresh", "0",
                 "--no-timelapse", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert not any("fresh" in r for r in data["validation"]["robots"])
    assert not (out / "cache" / "fresh.json").exists()
    assert "fresh terrains" not in (out / "index.md").read_text()
    capsys.readouterr()
    for count, why in (("-1", "fresh=-1: must be a whole number (0: no fresh terrains)"),
                       ("1001", "fresh=1001: must be at most 1000"),
                       ("x", "fresh='x': must be an integer")):
        args = ["report", str(campaign), "--out", str(tmp_path / "r"), "--fresh", count]
        try:
            code = main(args)
        except SystemExit as stop:  # argparse's own: a count that is no integer
            code = stop.code
        assert code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and why in err, err
        assert not (tmp_path / "r").exists()


def test_figures_by_omega_of_one_group_are_neither_drawn_nor_shown(campaign, report, tmp_path):
    """paper-rq1's layout: one experiment feeds Figure 10 and Figure 3 alike; Figures 10 and 11
    would be Figures 3 and 5 again, so the report writes no file of them."""
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    spec = json.loads((copy / "campaign.json").read_text())
    spec["experiments"]["rq1"]["figures"] = {"figure3": "omega 1", "figure5": "graph",
                                             "figure10": "omega 1 (neutral)"}
    spec["experiments"]["ablation"]["figures"] = {"figure5": "weights only"}
    (copy / "campaign.json").write_text(json.dumps(spec))
    out = tmp_path / "report"
    shutil.copytree(report[0], out)  # its caches: nothing is simulated
    assert main(["report", str(copy), "--out", str(out), "--no-timelapse", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert data["figure10"]["files"] == [] and data["figure10"]["curves"]
    assert data["figure11"]["files"] == {"logged": [], "validation": []}
    assert all(list(c["logged"]["groups"]) == ["omega 1 (neutral)"]
               for c in data["figure11"]["comparison"].values())
    names = {p.name for p in (out / "figures").iterdir()}
    assert "figure3.svg" in names and "figure5-logged.svg" in names
    assert not {n for n in names if n.startswith(("figure10", "figure11"))}
    assert "*One group only (rq1: omega 1 (neutral))" in (out / "index.md").read_text()


def test_a_finished_task_that_cannot_be_read_is_shown_as_missing(campaign, tmp_path, capsys):
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    (copy / "rq1" / "biped-s1" / "log.csv").write_text("not,a,log\n")
    (copy / "rq2-homo" / "worm-s0+s1-reopt" / "done.json").unlink()
    out = tmp_path / "report"
    assert main(["report", str(copy), "--out", str(out), "--no-timelapse", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert "rq1/biped-s1" in data["status"]["unreadable"]
    assert "rq1/biped-s1" in data["status"]["experiments"]["rq1"]["missing"]
    assert "rq2-homo/worm-s0+s1-reopt" in data["status"]["experiments"]["rq2-homo"]["missing"]
    row = next(r for r in data["table1"] if (r["experiment"], r["shape"]) == ("rq1", "biped"))
    assert (row["n"], row["missing"]) == (2, ["rq1/biped-s1"])
    assert len(data["figure7"]["curves"]["worm"]["homogeneous"]["tasks"]) == 2
    assert data["timelapse"] == []


_HEAD = ('{"format": "somite-campaign", "version": 1, "name": "x", "source": "test", '
         '"experiments": {"a": {}}, ')


@pytest.mark.parametrize("damage, field", [
    (None, "campaign"),
    ("not json", "campaign"),
    (_HEAD + '"tasks": [{"id": "a/b", "experiment": "a", "kind": "evolve", "path": "../b", '
     '"needs": [], "options": {}}]}', "campaign.json: tasks[0].path"),
    (_HEAD + '"tasks": [{"id": "a/b", "experiment": "a", "kind": "bake", "path": "a/b", '
     '"needs": [], "options": {}}]}', "campaign.json: tasks[0].kind"),
    ('{"format": "somite-campaign", "version": 2, "tasks": []}', "campaign.version"),
])
def test_bad_campaign_is_one_line_and_exit_2(tmp_path, capsys, damage, field):
    if damage is not None:
        (tmp_path / "campaign.json").write_text(damage)
    assert main(["report", str(tmp_path), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"error: {field}=" in err
    assert not (tmp_path / "r").exists()


def test_campaign_run_smoke_then_report(smoke_campaign, tmp_path):
    # A copy: the executed smoke campaign is the suite's, read by other tests meanwhile.
    campaign = tmp_path / "smoke"
    shutil.copytree(smoke_campaign, campaign)
    out = tmp_path / "report"
    assert main(["report", str(campaign), "--out", str(out), "--no-timelapse", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert all(s["done"] == s["tasks"] > 0 and not s["missing"]
               for s in data["status"]["experiments"].values())
    check_sections(out, data)
    check_table1(campaign, data)
    check_p_values(campaign, data)
    check_validation(campaign, data, 10)
    for figure in ("figure7", "figure8", "rq3_reassembly"):
        assert set(data[figure]["curves"]) == {"biped", "worm"}
    # report.json's entries in the order main's code wrote them (tests/data/report-smoke).
    assert skeleton(data) == skeleton(smoke_report())


OWN_NAMES = {"rq1": "graph", "ablation": "fixed-topology", "rq2-homo": "swap",
             "rq2-hetero": "cross-swap"}
OWN_FIGURES = {"graph": {"table1": "", "figure3": "graph", "figure5": "topology + weights"},
               "fixed-topology": {"figure5": "weights only"},
               "swap": {"figure7": "same shape"}, "cross-swap": {"figure7": "other shape"},
               "rq3-reassembly": {"discovered": "compact modules"}}


def _renamed(value):
    """``value`` with every task id of a renamed experiment (``rq1/...``) renamed."""
    if isinstance(value, dict):
        return {_renamed(k): _renamed(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_renamed(v) for v in value]
    if isinstance(value, str):
        old, slash, rest = value.partition("/")
        if old in OWN_NAMES and (slash or value == old):
            return OWN_NAMES[old] + slash + rest
    return value


def _report_again(copy, doc: dict, report, tmp_path):
    """The report of the campaign folder ``copy`` under the campaign.json ``doc``, with the
    first report's cache (the same robots: nothing re-run): its folder and report.json."""
    (copy / "campaign.json").write_text(json.dumps(doc))
    out = tmp_path / "report"
    shutil.copytree(report[0] / "cache", out / "cache")
    assert main(["report", str(copy), "--out", str(out), "--no-timelapse", "--quiet"]) == 0
    return out, json.loads((out / "report.json").read_text())


def test_a_campaign_of_its_own_names_gets_the_figures_it_declares(campaign, report, tmp_path):
    """The finished campaign with its experiments renamed and declaring their figures, as a
    user's TOML campaign writes campaign.json: the figures it declares are drawn from them,
    and one line names those no experiment feeds (no omega experiments)."""
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    for old, new in OWN_NAMES.items():
        (copy / old).rename(copy / new)
    doc = _renamed(json.loads((copy / "campaign.json").read_text()))
    for name, info in doc["experiments"].items():
        info["figures"] = OWN_FIGURES.get(name, {})
    out, data = _report_again(copy, doc, report, tmp_path)
    first = report[1]
    assert data["figure3"]["curves"]["worm"]["graph"] == first["figure3"]["curves"]["worm"][
        "omega 1"] | {"runs": [_renamed(r) for r in first["figure3"]["curves"]["worm"][
            "omega 1"]["runs"]]}
    for shape in ("biped", "worm"):
        assert data["figure5"]["one_sided"][shape]["logged"]["p"] == first["figure5"][
            "one_sided"][shape]["logged"]["p"]
        assert set(data["figure7"]["curves"][shape]) == {"same shape", "other shape"}
        # Its homogeneous reassembly of the same donors sits beside the discovered modules,
        # whatever Figure 7 calls it.
        beside = data["rq3_reassembly"]["curves"][shape]
        assert set(beside) == {"compact modules", "paper partition, same donors"}
        assert beside["paper partition, same donors"]["tasks"] == [f"swap/{shape}-s0+s1-reopt"]
    rows = {(r["experiment"], r["shape"]): r for r in data["table1"]}
    assert rows["graph", "worm"]["paper"]["final"]["size"]["value"] == 216.0
    assert rows["fixed-topology", "worm"]["paper"] is None
    assert set(data["figures"]["missing"]) == {"figure10", "figure8"}
    assert data["figure10"]["curves"] == {} and data["figure9"]["eta"] == {}
    text = (out / "index.md").read_text()
    [line] = [line for line in text.splitlines() if line.startswith("Figures no experiment")]
    assert "figure10: no evolve experiment declares it" in line
    assert "Figures no experiment" not in (report[0] / "index.md").read_text()


def test_a_campaign_without_figures_says_not_declared_and_groups_its_variants(campaign,
                                                                             report, tmp_path):
    """The user guide's kind of campaign file: one evolve experiment with two variants
    (rq1's runs as ``base/modular``, ablation's as ``base/plain``) and no ``figures`` table.
    The report says the figures are not declared, and shows each variant as a group: two
    rows of Table 1 a shape, two curves in Figure 3, a test between them in Figure 5."""
    copy = tmp_path / "campaign"
    copy.mkdir()
    doc = json.loads((campaign / "campaign.json").read_text())
    tasks = []
    for task in doc["tasks"]:
        variant = {"rq1": "modular", "ablation": "plain"}.get(task["experiment"])
        if variant is None or task["kind"] != "evolve":
            continue
        name = f"base/{variant}-{task['id'].split('/', 1)[1]}"
        if (campaign / task["path"]).is_dir():
            shutil.copytree(campaign / task["path"], copy / name)
        tasks.append({**task, "id": name, "path": name, "experiment": "base"})
    doc["tasks"] = tasks
    doc["experiments"] = {"base": {"title": "", "paper": "", "figures": {}}}
    out, data = _report_again(copy, doc, report, tmp_path)
    first = report[1]
    assert data["figures"]["declared"] is False and data["figures"]["missing"] == {}
    rows = {(r["experiment"], r["shape"]): r for r in data["table1"]}
    before = {(r["experiment"], r["shape"]): r for r in first["table1"]}
    assert set(rows) == {(f"base/{v}", s) for v in ("modular", "plain")
                         for s in ("biped", "worm")}
    for shape in ("biped", "worm"):
        for variant, experiment in (("modular", "rq1"), ("plain", "ablation")):
            assert rows[f"base/{variant}", shape]["final"] == before[experiment, shape]["final"]
        assert list(data["figure3"]["curves"][shape]) == ["base/modular", "base/plain"]
        [test] = data["figure5"]["comparison"][shape]["logged"]["tests"]
        assert test["p"] == first["figure5"]["comparison"][shape]["logged"]["tests"][0]["p"]
        assert data["figure5"]["one_sided"][shape]["logged"]["p"] == first["figure5"][
            "one_sided"][shape]["logged"]["p"]
    text = (out / "index.md").read_text()
    assert "Figures: not declared" in text and "Figures no experiment feeds" not in text
    assert "No pair to test" not in text.split("## Figure 5")[1].split("## Figure 11")[0]


def test_an_interim_report_draws_the_runs_under_way_in_the_curves_only(campaign, report,
                                                                       tmp_path, capsys):
    """``--under-way``: a run still writing its log is a curve to its last complete row, named
    in the banner, in no table, test or final figure, and its best of that generation is drawn
    as a time-lapse after the finished ones'."""
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    for name, cut in (("log.csv", 10), ("bests.jsonl", 100)):  # generations 0 and 1, then a
        path = copy / UNFINISHED[0] / name                      # line still being written
        lines = path.read_text().splitlines(keepends=True)
        path.write_text("".join(lines[:2 + (name == "log.csv")]) + lines[-1][:cut])
    out = tmp_path / "report"
    shutil.copytree(report[0], out)  # its caches: only the run under way is simulated
    assert main(["report", str(copy), "--out", str(out), "--under-way", "--quiet"]) == 0
    data = json.loads((out / "report.json").read_text())
    assert data["cache"] == {"genomes_simulated": 0, "strips_drawn": 1}
    strip = data["status"]["under_way"][UNFINISHED[0]].pop("strip")
    assert data["status"]["under_way"] == {UNFINISHED[0]: {"generation": 1, "generations": 2}}
    best = json.loads((copy / UNFINISHED[0] / "bests.jsonl").read_text().splitlines()[1])
    assert (strip["generation"], strip["logged"]) == (1, best["velocity"])
    assert (out / "figures" / strip["file"]).is_file()
    assert (out / "figures" / strip["replay"]).is_file()
    worm = data["figure3"]["curves"]["worm"]["omega 1"]
    assert worm["under_way"] == {UNFINISHED[0]: 1} and UNFINISHED[0] in worm["runs"]
    finished = [_log(f) for f in _finished(campaign, "rq1", "worm")]
    starts = [float(log[0]["best_velocity"]) for log in finished] + [
        float(_log(copy / UNFINISHED[0])[0]["best_velocity"])]
    assert worm["velocity_median"][0] == float(np.median(starts))
    # the last generation's curve is the finished runs' alone
    assert worm["velocity_median"][-1] == report[1]["figure3"]["curves"]["worm"]["omega 1"][
        "velocity_median"][-1]
    assert data["table1"] == report[1]["table1"]
    matched = data["figure5"].pop("matched")
    assert data["figure5"] == report[1]["figure5"] and "matched" not in report[1]["figure5"]
    # Figure 5 so far adds nothing: the run under way is behind finished runs of its group,
    # and both groups are compared at generation 2, where only finished runs are.
    assert matched == {}
    # The cuts draw it to its last whole best, and compare nothing more than Figure 5 does.
    cuts = data["cuts_during_evolution"]
    assert cuts["under_way"] == {UNFINISHED[0]: 1} and cuts["matched"] == {}
    assert UNFINISHED[0] in cuts["curves"]["worm"]["omega 1 (neutral)"]["runs"]
    assert cuts["final"] == report[1]["cuts_during_evolution"]["final"]
    assert data["timelapse"] == report[1]["timelapse"]
    assert UNFINISHED[0] not in {r["task"] for r in data["validation"]["robots"]}
    assert data["caveats"]["under_way"]["tasks"] == [UNFINISHED[0]]
    text = (out / "index.md").read_text()
    assert text.count("**Warning:** interim report: 1 run still under way "
                      f"({UNFINISHED[0]} at generation 1 of 2)") == 1
    assert f"{UNFINISHED[0]} (generation 1)" in text
    runs = len(worm["runs"])
    assert f"| worm | omega 1 | {runs} ({runs - 1} at the last) | 2 |" in text
    assert "So far, at the same budget" not in text
    assert f"### Under way: {UNFINISHED[0]}, its best at generation 1" in text
    assert f"Gait: {strip['gait']}." in text
    assert "interim report" in capsys.readouterr().err
    # without the flag the same campaign's report draws finished runs only
    assert report[1]["status"]["under_way"] == {}
    assert report[1]["figure3"]["curves"]["worm"]["omega 1"]["under_way"] == {}
    # The next report without the flag (or once the run has finished) names no strip of it, and
    # leaves none beside it: the strip, its page and their cache entries are gone.
    assert main(["report", str(copy), "--out", str(out), "--quiet"]) == 0
    assert not (out / "figures" / strip["file"]).exists()
    assert not (out / "figures" / strip["replay"]).exists()
    cached = json.loads((out / "cache" / "timelapse.json").read_text())["entries"]
    assert not any(key.startswith(strip["file"]) or key.startswith(strip["replay"])
                   for key in cached)
    assert (out / "figures" / data["timelapse"][0]["file"]).is_file()
