"""The report's section on the final bests' edge lengths (issue 72), on ``lengths-smoke`` as
``somite campaign run`` executes it: the counts are those of the task folders' ``best.json``,
an interim report counts the finished runs only, and a campaign folder written before its
experiments declared the section still gets it."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
from collections import Counter

import numpy as np
import pytest

from somite.brain.delays import edge_lengths, length_counts
from somite.brain.genome import Genome
from somite.campaigns.builtin import EDGE_LENGTH_VARIANTS
from somite.cli import main
from somite.report.campaign import read_campaign
from somite.report.edge_lengths import CSV, CSV_COLUMNS, KEY, TITLE, render
from somite.report.markdown import render_html, render_markdown

GROUPS = list(EDGE_LENGTH_VARIANTS)
SHAPES = ("biped", "worm")
SEEDS = (0, 1, 2)
REPORT = ["--validation", "2", "--fresh", "0", "--no-timelapse", "--quiet"]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("lengths") / "campaign"
    done = subprocess.run([sys.executable, "-m", "somite.cli", "campaign", "run",
                           "lengths-smoke", "--out", str(out), "--workers", "1", "--threads",
                           "1", "--yes", "--quiet"], capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    return out


@pytest.fixture(scope="module")
def report(campaign, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    assert main(["report", str(campaign), "--out", str(out), *REPORT]) == 0
    return out, json.loads((out / "report.json").read_text())


def _best(campaign, group, shape, seed) -> Genome:
    return Genome.load(campaign / group / f"{shape}-s{seed}" / "best.json")


def _csv(out) -> list[dict]:
    with open(out / "figures" / CSV, newline="") as handle:
        return list(csv.DictReader(handle))


def test_each_groups_edges_are_counted_by_length_from_its_final_bests(campaign, report):
    out, data = report
    shapes = data[KEY]["shapes"]
    assert list(shapes) == list(SHAPES)
    for shape in SHAPES:
        assert list(shapes[shape]) == GROUPS
        for group in GROUPS:
            bests = [_best(campaign, group, shape, seed) for seed in SEEDS]
            entry = shapes[shape][group]
            counts = length_counts(bests)
            assert dict(zip(entry["lengths"], entry["counts"])) == counts
            assert entry["edges"] == sum(len(g.edges) for g in bests) == sum(counts.values())
            assert entry["runs"] == [f"{group}/{shape}-s{s}" for s in SEEDS]
            assert (entry["tasks"], entry["missing"]) == (3, [])
            assert entry["inside_voxel"] == counts.get(0.0, 0) / entry["edges"]
            assert entry["side_neighbour"] == counts.get(1.0, 0) / entry["edges"]
            assert entry["inside_voxel"] + entry["side_neighbour"] + entry["longer"] == \
                pytest.approx(1.0)
            assert entry["mean"] == pytest.approx(np.mean(np.concatenate(
                [edge_lengths(g) for g in bests])), abs=1e-12)
            for seed, genome in zip(SEEDS, bests):
                run = entry["per_run"][f"{group}/{shape}-s{seed}"]
                assert dict(zip(run["lengths"], run["counts"])) == length_counts([genome])


def test_the_csv_holds_every_runs_counts_and_sums_to_the_table(campaign, report):
    out, data = report
    rows = _csv(out)
    assert tuple(rows[0]) == CSV_COLUMNS
    per_run = Counter()
    for row in rows:
        per_run[row["task"], float(row["length_voxels"])] += int(row["edges"])
        assert row["experiment"] == row["group"] == row["task"].split("/")[0]
        assert row["shape"] == row["task"].split("/")[1].split("-")[0]
    expected = Counter()
    for group in GROUPS:
        for shape in SHAPES:
            for seed in SEEDS:
                for length, count in length_counts([_best(campaign, group, shape,
                                                          seed)]).items():
                    expected[f"{group}/{shape}-s{seed}", length] = count
    assert per_run == expected
    assert len(rows) == len(expected)


def test_index_md_shows_the_section_after_the_evolve_figures(report):
    out, data = report
    text = (out / "index.md").read_text()
    assert text.index("## Figure 11") < text.index(f"## {TITLE}") < text.index(
        "## Figures 7 and 8")
    section = text.split(f"## {TITLE}")[1].split("\n## ")[0]
    for shape in SHAPES:
        for group in GROUPS:
            e = data[KEY]["shapes"][shape][group]
            share = f"{100 * e['inside_voxel']:.1f} %"
            assert f"| {shape} | {group} | 3 of 3 | {e['edges']} | {e['mean']:.3f} |" in section
            assert share in section
        assert f"{shape}: edges of each length" in section
    assert "| length [voxels] | neutral | distance-bias | length-delay |" in section
    assert "| 0.000 |" in section
    assert f"[CSV](figures/{CSV})" in section
    for name in data[KEY]["files"]:
        assert (out / "figures" / name).stat().st_size > 0
        assert f"figures/{name}" in text
    assert {name.rsplit(".", 1)[1] for name in data[KEY]["files"]} == {"png", "svg"}
    # Declared by the three, never a figure the campaign lacks.
    assert data["figures"]["fed"]["edge-lengths"] == {g: g for g in GROUPS}
    assert "edge-lengths" not in data["figures"]["missing"]


def test_an_interim_report_counts_the_finished_runs_only(campaign, report, tmp_path):
    """``--under-way`` with length-delay not finished (its runs' logs written, no done.json)
    and one distance-bias run missing: those groups count what finished, and say how many."""
    copy = tmp_path / "campaign"
    shutil.copytree(campaign, copy)
    for done in [*copy.glob("length-delay*/*/done.json"),
                 copy / "distance-bias" / "worm-s2" / "done.json",
                 *copy.glob("distance-bias-homo/worm-s*+s2*/done.json"),
                 *copy.glob("distance-bias-homo/worm-s2+*/done.json")]:
        done.unlink()
    out = tmp_path / "report"
    shutil.copytree(report[0] / "cache", out / "cache")
    assert main(["report", str(copy), "--out", str(out), "--under-way", *REPORT]) == 0
    data = json.loads((out / "report.json").read_text())
    assert "length-delay/worm-s0" in data["status"]["under_way"]
    shapes = data[KEY]["shapes"]
    for shape in SHAPES:
        delayed = shapes[shape]["length-delay"]
        assert (delayed["runs"], delayed["edges"], delayed["mean"]) == ([], 0, None)
        assert delayed["missing"] == [f"length-delay/{shape}-s{s}" for s in SEEDS]
        assert shapes[shape]["neutral"] == report[1][KEY]["shapes"][shape]["neutral"]
    worm = shapes["worm"]["distance-bias"]
    assert worm["missing"] == ["distance-bias/worm-s2"]
    assert dict(zip(worm["lengths"], worm["counts"])) == length_counts(
        [_best(campaign, "distance-bias", "worm", s) for s in (0, 1)])
    assert {r["task"] for r in _csv(out)} == {f"{g}/{s}-s{n}" for g in ("neutral",
                                                                        "distance-bias")
                                              for s in SHAPES for n in SEEDS} - {
        "distance-bias/worm-s2"}
    section = (out / "index.md").read_text().split(f"## {TITLE}")[1].split("\n## ")[0]
    assert "| worm | distance-bias | 2 of 3 |" in section
    assert "| worm | length-delay | 0 of 3 | 0 | n/a | n/a | n/a | n/a | n/a |" in section
    assert "| length [voxels] | neutral | distance-bias | length-delay |" in section
    # A group of no finished run is no sample: the run means are compared between the others.
    assert {shape: [(t["a"], t["b"], t["n_a"], t["n_b"]) for t in tests]
            for shape, tests in data[KEY]["run_mean_tests"].items()} == {
        "biped": [("neutral", "distance-bias", 3, 3)],
        "worm": [("neutral", "distance-bias", 3, 2)]}
    assert data[KEY]["files"]


def test_a_folder_written_before_the_declaration_still_gets_the_section(campaign, tmp_path):
    """The ``lengths`` campaign started before its experiments declared ``edge-lengths``: a
    built-in's folder is read with what its built-in declares now; a file's campaign is not."""
    copy = tmp_path / "campaign"
    copy.mkdir()
    doc = json.loads((campaign / "campaign.json").read_text())
    for info in doc["experiments"].values():
        info["figures"].pop("edge-lengths", None)
    (copy / "campaign.json").write_text(json.dumps(doc))
    found = read_campaign(copy)
    assert found.fed("edge-lengths") == {g: g for g in GROUPS}
    assert found.fed("figure3") == {g: g for g in GROUPS}
    doc["source"] = "lengths.toml"
    (copy / "campaign.json").write_text(json.dumps(doc))
    assert read_campaign(copy).fed("edge-lengths") == {}
    assert "edge-lengths" not in read_campaign(copy).missing_figures()


def test_a_groups_label_is_shown_as_text(report):
    """A label of a campaign file is escaped in every table that shows it, and never run as
    HTML."""
    data = json.loads(json.dumps(report[1]))
    label = "<script>x</script>|[a](javascript:b)"
    for shape in SHAPES:
        groups = data[KEY]["shapes"][shape]
        groups[label] = groups.pop("neutral")
    data[KEY]["run_mean_tests"] = {shape: [{**t, "a": label} for t in tests]
                                   for shape, tests in data[KEY]["run_mean_tests"].items()}
    text = "\n".join(render(data))
    assert label not in text and "<script>x</script>\\|\\[a\\](javascript:b)" in text
    assert text.count("\\|\\[a\\]") == 2 * len(SHAPES) + sum(
        len(t) for t in data[KEY]["run_mean_tests"].values())
    html = render_html(render_markdown(data), "lengths")
    if html is not None:
        assert "<script>" not in html and "&lt;script&gt;" in html
