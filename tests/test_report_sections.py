"""Each experiment kind's section of the report (:mod:`somite.report.sections`): one per kind,
in the kinds' order, and the smoke campaign's report written as main's code wrote it
(``tests/data/report-smoke``, made by ``somite report`` before the sections were split out)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from somite.campaigns.kinds import EXPERIMENT_KINDS
from somite.report import markdown, sections
from somite.report.load import Loaded
from somite.report.section import Section, add_entries

SMOKE = Path(__file__).resolve().parent / "data" / "report-smoke"


def smoke_report() -> dict:
    """report.json of the smoke campaign, as main's code wrote it."""
    return json.loads(gzip.decompress((SMOKE / "report.json.gz").read_bytes()))


def skeleton(report: dict) -> list:
    """report.json's entries in order, each with its own entries' names in order (the names
    one level down do not depend on the campaign's numbers)."""
    return [(key, list(value) if isinstance(value, dict) else type(value).__name__)
            for key, value in report.items()]


def test_every_experiment_kind_has_a_section():
    assert list(sections.SECTIONS) == list(EXPERIMENT_KINDS)
    assert all(isinstance(s, Section) for s in sections.in_order())


def test_index_md_of_the_smoke_report_is_the_one_main_wrote():
    expected = (SMOKE / "index.md").read_text(encoding="utf-8")
    assert markdown.render_markdown(smoke_report()) == expected


def test_a_new_kind_shows_its_section_after_the_others(monkeypatch):
    """A kind's section is all the report needs of it: its entry in SECTIONS (and its kind
    in EXPERIMENT_KINDS) puts its lines between the built-in kinds' and the shared ones."""
    extra = Section(lambda inputs: {"bake": {"loaves": 3}},
                    lambda report: [f"## Baked: {report['bake']['loaves']} loaves", ""])
    monkeypatch.setattr(sections, "SECTIONS", {**sections.SECTIONS, "bake": extra})
    monkeypatch.setattr(sections, "EXPERIMENT_KINDS", (*EXPERIMENT_KINDS, "bake"))
    report = {**smoke_report(), "bake": {"loaves": 3}}
    report["campaign"]["kinds"].append("bake")
    text = markdown.render_markdown(report)
    assert text.index("## Figure 12") < text.index("## Baked: 3 loaves") < text.index(
        "## Beyond the paper: every final best")


def test_two_sections_with_one_entry_are_refused():
    report = {"figure3": {}}
    add_entries(report, {"bake": 1})
    assert list(report) == ["figure3", "bake"]
    with pytest.raises(ValueError, match="figure3"):
        add_entries(report, {"figure3": 2})


def test_what_a_new_kind_reads_is_kept_under_its_own_name():
    loaded = Loaded()
    loaded.add("bake/a", {"runs": "log", "loaves": 3})
    assert loaded.runs == {"bake/a": "log"}
    assert loaded.found("loaves") == {"bake/a": 3} and loaded.other == {"loaves": {"bake/a": 3}}


def test_a_figure_without_two_finished_groups_says_why_it_has_no_test():
    """An interim report of one finished run: Figure 5 says it has nothing to test, where it
    showed the header of an empty table."""
    report = smoke_report()
    for comparison in report["figure5"]["comparison"].values():
        for sample in ("logged", "validation"):
            comparison[sample]["tests"] = []
    text = markdown.render_markdown(report)
    figure5 = text.split("## Figure 5")[1].split("\n## ")[0]
    assert "*No pair to test: no shape has finished tasks in two groups.*" in figure5
    assert "| sample | pair |" not in figure5
    assert text.count("| sample | pair |") == 3  # Figure 11's, the cuts' and Figure 9's stay


def test_a_campaign_of_evolve_experiments_alone_shows_no_empty_reassembly_sections():
    """paper-rq1 has evolve experiments only: Figures 7-9 and 12 would be headers of empty
    tables, so index.md leaves them out and says so once; a report.json written before
    ``campaign.kinds`` existed still shows every section."""
    everything = markdown.render_markdown(smoke_report())
    report = smoke_report()
    report["campaign"]["kinds"] = ["evolve"]
    report["figures"]["missing"] = {"figure7": "no reassemble experiment declares it",
                                    "figure10": "no evolve experiment declares it"}
    text = markdown.render_markdown(report)
    for title in ("## Figures 7 and 8", "## Figure 9", "## Figure 12"):
        assert title in everything and title not in text
    for title in ("## Figure 3", "## Figure 5", "## Beyond the paper: every final best"):
        assert title in text
    assert "The campaign has no reassemble or discover experiment: the report leaves out " \
           "their sections." in text
    assert "left empty: figure10: no evolve experiment declares it." in text
    assert "figure7" not in text.split("## Figure 3")[0]


def test_an_undeclared_table_1_is_shown_not_called_empty():
    """Table 1 lists every evolve experiment whether or not one declares it (a declaration
    puts the paper's row beside it): the report must not call it left empty."""
    report = smoke_report()
    report["figures"]["missing"] = {"table1": "no evolve experiment declares it",
                                    "figure10": "no evolve experiment declares it"}
    head = markdown.render_markdown(report).split("## Table 1")[0]
    assert "Table 1 shows every evolve experiment, the paper's row beside none (table1: no " \
           "evolve experiment declares it)." in head
    assert "left empty: figure10: no evolve experiment declares it." in head
    assert "table1: no evolve" not in head.split("left empty")[1]


def test_figures_by_omega_of_one_group_point_to_figures_3_and_5():
    """paper-rq1 has one omega: Figures 10 and 11 would draw Figure 3's and 5's runs again."""
    report = smoke_report()
    report["figures"]["fed"]["figure10"] = {"rq1": "omega 1 (neutral)"}
    text = markdown.render_markdown(report)
    by_omega = text.split("## Figure 10")[1].split("## Figure 5")[0]
    assert "*One group only (rq1: omega 1 (neutral)), whose runs Figure 3 shows: nothing to " \
           "compare by omega.*" in by_omega
    assert "![" not in by_omega
    final = text.split("## Figure 11")[1].split("\n## ")[0]
    assert "whose runs Figure 5 shows" in final and "![" not in final and "| sample" not in final
    assert "![Figure 3" in text and "![Figure 5" in text
    # An experiment that feeds Figure 10 alone is still drawn there.
    report["figures"]["fed"]["figure10"] = {"omega-10": "omega 10"}
    assert "![Figure 10" in markdown.render_markdown(report)


def _run(last: int, velocity: float, every: int = 50):
    """A run's log to generation ``last``: best v_x ``velocity`` + g/1000, its validation
    (every ``every`` generations) half of that."""
    import numpy as np

    from somite.analysis.stats import RunLog

    generation = np.arange(last + 1, dtype=float)
    best = velocity + generation / 1000
    validation = np.where(generation % every == 0, best / 2, np.nan)
    return RunLog(Path("."), {}, {"generation": generation, "best_velocity": best,
                                  "validation_velocity": validation})


def test_figure5_so_far_compares_the_groups_at_the_same_budget():
    """An interim report's Figure 5 compares each shape's groups at the furthest generation
    every group has validated (paper-rq1: the graph worm finished, the weights-only worm at
    2109, validated at 2100), with the runs that reached it; a shape whose compared runs have
    all finished is left out (the final table shows them)."""
    from somite.report.evolution import matched

    found = {
        "worm": {"graph": {"rq1/worm-s0": _run(3000, 1.0), "rq1/worm-s1": _run(40, 0.5)},
                 "weights": {"ablation/worm-s0": _run(2109, 2.0)}},
        "biped": {"graph": {"rq1/biped-s0": _run(3000, 3.0), "rq1/biped-s1": _run(66, 0.1)},
                  "weights": {"ablation/biped-s0": _run(3000, 1.0)}},
    }
    under_way = {i: found[s][g][i] for s, g, i in (
        ("worm", "graph", "rq1/worm-s1"), ("worm", "weights", "ablation/worm-s0"),
        ("biped", "graph", "rq1/biped-s1"))}
    out = matched(found, under_way)
    assert list(out) == ["worm"] and out["worm"]["generation"] == 2100
    assert out["worm"]["groups"] == {
        "graph": {"runs": ["rq1/worm-s0"], "under_way": [], "logged": 1.0 + 2.1,
                  "validation": (1.0 + 2.1) / 2},
        "weights": {"runs": ["ablation/worm-s0"], "under_way": ["ablation/worm-s0"],
                    "logged": 2.0 + 2.1, "validation": (2.0 + 2.1) / 2}}
    # Both worm graph runs past 2100: the median of the two.
    found["worm"]["graph"]["rq1/worm-s1"] = _run(2500, 0.5)
    assert matched(found, under_way)["worm"]["groups"]["graph"]["logged"] == 0.75 + 2.1
    # A group validated at generation 0 alone, or one group alone: nothing to compare.
    found["worm"]["weights"] = {"ablation/worm-s0": _run(40, 2.0)}
    assert matched(found, under_way) == {}
    del found["worm"]["weights"]
    assert matched(found, under_way) == {}
    # Rendered under Figure 5's table, naming the run under way.
    report = smoke_report()
    found["worm"]["weights"] = {"ablation/worm-s0": _run(2109, 2.0)}
    report["figure5"]["matched"] = matched(found, under_way)
    text = markdown.render_markdown(report).split("## Figure 5")[1].split("\n## ")[0]
    assert "| worm | 2100 | weights | 1 | ablation/worm-s0 | 4.100 | 2.050 |" in text
    assert "| worm | 2100 | graph | 2 | rq1/worm-s1 | 2.850 | 1.425 |" in text


def test_a_figure_of_two_undrawn_images_says_so_once():
    """Figure 5 has two images (logged and validation v_x): with neither drawn, its section
    said "no finished task" twice; each figure says it once, and an image it has is shown."""
    from somite.report.text import NO_TASK, images_of

    assert images_of([([], "logged"), ([], "validation")]) == [NO_TASK, ""]
    shown = images_of([(["f.png"], "logged"), ([], "validation")])
    assert shown.count(NO_TASK) == 1 and "![logged](figures/f.png)" in shown
    report = smoke_report()
    report["figure5"]["files"] = {"logged": [], "validation": []}
    figure5 = markdown.render_markdown(report).split("## Figure 5")[1].split("\n## ")[0]
    assert figure5.count(NO_TASK) == 1
