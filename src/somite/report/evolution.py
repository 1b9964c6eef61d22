"""The evolution experiments in numbers: Table 1, the curves of Figures 3 and 10 and the
final-v_x comparisons of Figures 5 and 11 (each also on the validation terrains).

Runs are grouped per shape (biped, worm) and per experiment that feeds the figure, as the
campaign declares (``campaign.fed("figure3")``: experiment -> label; in the built-ins ``rq1``
for Figure 3, ``rq1`` and ``ablation`` for Figure 5, the omega experiments for Figures 10 and
11, ``rq1`` beside the paper's Table 1). Statistics are those of :mod:`somite.analysis.stats`
(median, sd with ddof 0, two-sided Mann-Whitney U).
"""

from __future__ import annotations

import numpy as np

from ..analysis.stats import RunLog, describe, pairwise_mann_whitney, small_sample_caveat
from ..viz import report_figures as figures
from ..viz.plots import curve
from . import paper
from .campaign import CampaignFolder, Task
from .load import Loaded, shape_name
from .section import Inputs, Section
from .text import (
    claim,
    images,
    images_of,
    median_sd,
    number,
    p_noted,
    pair_rows,
    plain,
    table,
    tests_table,
)

TITLES = {
    "table1": "Table 1: the best controller at the start and at the end",
    "figure3": "Figure 3: best v_x and |G| over the generations",
    "figure10": "Figure 10: best v_x and |G| by omega",
    "figure5": "Figure 5: final best v_x, with and without topology optimisation",
    "figure11": "Figure 11: final best v_x by omega",
}
"""The heading of each of this section's entries in index.md, by its key in report.json (the
title drawn on its figure too)."""

SHAPES = ("biped", "worm")
"""The paper's panel order: biped left, worm right."""

Groups = dict[str, dict[str, dict[str, RunLog]]]
"""shape -> group label -> task id -> run."""


def task_shape(task: Task, loaded: Loaded) -> str:
    """The task's shape name: from its run when readable, else from its options or name."""
    if task.id in loaded.runs:
        return shape_name(loaded.runs[task.id].config["shape"])
    if isinstance(task.options.get("shape"), str):
        return shape_name(task.options["shape"])
    # "<shape>-s<seed>", or "<variant>-<shape>-s<seed>" in a campaign file with variants
    return shape_name(task.name.rsplit("-s", 1)[0].rsplit("-", 1)[-1])


def shape_order(shapes) -> list[str]:
    return sorted(set(shapes), key=lambda s: (SHAPES.index(s) if s in SHAPES else 9, s))


def group_label(label: str, variant: str) -> str:
    """A group's label: its experiment's label in the figure, and its variant (an evolve
    experiment with variants is a group per variant: ``base/modular``, ``base/plain``)."""
    return f"{label}/{variant}" if variant else label


def group_labels(campaign: CampaignFolder, members: dict[str, str]) -> list[str]:
    """The groups of the experiments ``members`` (id -> label), in the campaign's order."""
    return [group_label(label, variant) for experiment, label in members.items()
            for variant in campaign.variants(experiment)]


def groups(campaign: CampaignFolder, loaded: Loaded, members: dict[str, str],
           under_way: bool = False) -> Groups:
    """The finished runs of the experiments ``members`` (id -> label), per shape and group
    (:func:`group_label`); with ``under_way``, also the runs still under way that the report
    read."""
    found: dict[str, dict[str, dict[str, RunLog]]] = {}
    for experiment, label in members.items():
        for task in campaign.of(experiment, "evolve"):
            run = loaded.runs.get(task.id)
            if run is None and under_way:
                run = loaded.under_way.get(task.id)
            if run is not None:
                shape = shape_name(run.config["shape"])
                group = group_label(label, task.variant)
                found.setdefault(shape, {}).setdefault(group, {})[task.id] = run
    order = group_labels(campaign, members)
    return {s: {label: found[s][label] for label in order if label in found[s]}
            for s in shape_order(found)}


def _column(runs: dict[str, RunLog], column: str, row: int) -> list[float]:
    return [float(run.log[column][row]) for run in runs.values()]


def table1(campaign: CampaignFolder, loaded: Loaded, reruns: dict[str, dict]) -> list[dict]:
    """One row per evolve experiment (and variant: :func:`group_label`) and shape: initial and
    final |V|, |E|, |G| and v_x of the best (median, sd, ...), its v_x on the validation
    terrains, the paper's numbers."""
    rows = []
    for experiment in campaign.experiments:
        beside = experiment in campaign.fed("table1")
        for variant in campaign.variants(experiment):
            by_shape: dict[str, list[Task]] = {}
            for task in campaign.of(experiment, "evolve"):
                if task.variant == variant:
                    by_shape.setdefault(task_shape(task, loaded), []).append(task)
            for shape in shape_order(by_shape):
                row = _table1_numbers(by_shape[shape], loaded, reruns)
                rows.append({"experiment": group_label(experiment, variant), "shape": shape,
                             **row, "paper": _paper_table1(shape) if beside else None})
    return rows


def _table1_numbers(tasks: list[Task], loaded: Loaded, reruns: dict[str, dict]) -> dict:
    runs = {t.id: loaded.runs[t.id] for t in tasks if t.id in loaded.runs}
    row = {
        "tasks": len(tasks), "n": len(runs), "missing": [t.id for t in tasks if t.id not in runs],
        "generations": describe([run.final("generation") for run in runs.values()]),
    }
    for when, index in (("initial", 0), ("final", -1)):
        row[when] = {name: describe(_column(runs, column, index)) for name, column in (
            ("nodes", "best_nodes"), ("edges", "best_edges"), ("size", "best_size"),
            ("velocity", "best_velocity"))}
    # A robot that went non-finite on a validation terrain has no mean v_x: counted
    # apart, so that one such robot does not hide the others' median.
    means = np.array([reruns[i]["mean"] for i in runs if i in reruns])
    row["validation"] = describe(means[np.isfinite(means)])
    row["validation_non_finite"] = int(np.sum(~np.isfinite(means)))
    row["size_increase"] = _increase(row)
    return row


def _increase(row: dict) -> float:
    start, end = row["initial"]["size"]["median"], row["final"]["size"]["median"]
    return end / start - 1 if start == start and start else float("nan")


def _paper_table1(shape: str) -> dict | None:
    if shape not in paper.TABLE1:
        return None
    rows = paper.TABLE1[shape]
    return {
        **{when: {k: r.to_dict() for k, r in rows[when].items()} for when in rows},
        "size_increase": paper.SIZE_INCREASE[shape].to_dict(),
    }


def curves(found: Groups, under_way: dict[str, RunLog] | None = None) -> dict:
    """Per shape and group: median and sd across runs, per generation, of the best's v_x and
    |G|, and the median of the logged validation v_x where it was measured; ``under_way``:
    each of the group's runs that is among ``under_way`` (not finished), with the last
    generation it logged."""
    under_way = under_way or {}
    out = {}
    for shape, labelled in found.items():
        out[shape] = {}
        for label, runs in labelled.items():
            generation, v_median, v_sd = curve(list(runs.values()), "best_velocity")
            _, g_median, g_sd = curve(list(runs.values()), "best_size")
            x, validation, _ = curve(list(runs.values()), "validation_velocity")
            shown = np.isfinite(validation)
            out[shape][label] = {
                "runs": list(runs),
                "under_way": {i: int(run.log["generation"][-1]) for i, run in runs.items()
                              if i in under_way},
                "generation": generation.tolist(),
                "velocity_median": v_median.tolist(), "velocity_sd": v_sd.tolist(),
                "size_median": g_median.tolist(), "size_sd": g_sd.tolist(),
                "validation_generation": x[shown].tolist(),
                "validation_median": validation[shown].tolist(),
            }
    return out


def compare(samples: dict[str, list[float]], ids: dict[str, list[str]] | None = None) -> dict:
    """Per group its values (NaN dropped) and summary, and a two-sided Mann-Whitney U test
    for every pair of groups (with its ``caveat`` where a group is too small)."""
    clean = {k: [float(v) for v in values if np.isfinite(v)] for k, values in samples.items()}
    groups_out = {}
    for label, values in clean.items():
        groups_out[label] = {"values": values, **describe(values)}
        if ids is not None:
            groups_out[label]["tasks"] = ids[label]
    tests = [t.to_dict() for t in pairwise_mann_whitney(clean)]
    return {"groups": groups_out, "tests": tests}


def final_comparison(found: Groups, reruns: dict[str, dict]) -> dict:
    """Per shape: the last generation's best v_x per group (logged, as the paper) and the
    same bests' mean v_x on the validation terrains, each with the pairwise tests."""
    out = {}
    for shape, labelled in found.items():
        ids = {label: list(runs) for label, runs in labelled.items()}
        logged = {label: [run.final("best_velocity") for run in runs.values()]
                  for label, runs in labelled.items()}
        validated = {label: [reruns[i]["mean"] for i in runs] for label, runs in labelled.items()}
        out[shape] = {"logged": compare(logged, ids), "validation": compare(validated, ids)}
    return out


def matched(found: Groups, under_way: dict[str, RunLog]) -> dict:
    """Figure 5 so far, while some of its runs are under way: per shape with two groups or
    more, the furthest generation every group has reached (the least, over the groups, of the
    last generation any of its runs validated), and per group the median logged best v_x and
    validation v_x there of the runs that validated at it. The groups are compared at the same
    budget; nothing is tested (the final comparison does that). A shape is left out where that
    generation is 0 (no evolution yet) or its compared runs have all finished (the final
    comparison shows them)."""
    out = {}
    for shape, labelled in found.items():
        same = same_budget(labelled, _validated, set(under_way))
        if same is None:
            continue
        generation, at = same
        out[shape] = {"generation": generation, "groups": {}}
        for label, rows in at.items():
            group = labelled[label]
            out[shape]["groups"][label] = {
                "runs": list(rows),
                "under_way": [i for i in rows if i in under_way],
                "logged": float(np.median([group[i].log["best_velocity"][k]
                                           for i, k in rows.items()])),
                "validation": float(np.median([group[i].log["validation_velocity"][k]
                                               for i, k in rows.items()])),
            }
    return out


def same_budget(labelled: dict[str, dict[str, RunLog]], rows_of,
                under_way: set[str]) -> tuple[int, dict[str, dict[str, int]]] | None:
    """Where a shape's groups (label -> task id -> run) compare at the same budget: the
    furthest generation every group has reached (the least, over the groups, of the last
    generation any of its runs has among ``rows_of(run)``: generation -> row of its log), and
    per group the runs that reached it with their row there. None with fewer than two groups,
    where that generation is 0 (no evolution yet), or where its compared runs have all
    finished (none among ``under_way``)."""
    if len(labelled) < 2:
        return None
    rows = {i: rows_of(run) for group in labelled.values() for i, run in group.items()}
    generation = min(max((max(rows[i], default=-1) for i in group), default=-1)
                     for group in labelled.values())
    at = {label: {i: rows[i][generation] for i in group if generation in rows[i]}
          for label, group in labelled.items()}
    compared = {i for found in at.values() for i in found}
    if generation < 1 or not all(at.values()) or not compared & under_way:
        return None
    return generation, at


def _validated(run: RunLog) -> dict[int, int]:
    """The generations at which ``run`` logged a validation v_x -> their row in its log."""
    rows = np.flatnonzero(np.isfinite(run.log["validation_velocity"]))
    return {int(run.log["generation"][k]): int(k) for k in rows}


def one_sided(comparison: dict, a: str, b: str) -> dict | None:
    """The paper's test of Figure 5: one-sided Mann-Whitney U, H1 'group ``a`` is faster than
    group ``b``' (section 5.1.1); None when a group is missing or empty."""
    groups = comparison["groups"]
    if not groups.get(a, {}).get("values") or not groups.get(b, {}).get("values"):
        return None
    from scipy.stats import mannwhitneyu

    n_a, n_b = len(groups[a]["values"]), len(groups[b]["values"])
    result = mannwhitneyu(groups[a]["values"], groups[b]["values"], alternative="greater")
    return {"test": "mann-whitney-u, one-sided (a > b)", "a": a, "b": b, "n_a": n_a,
            "n_b": n_b, "u": float(result.statistic), "p": float(result.pvalue),
            "caveat": small_sample_caveat(n_a, n_b)}


def build(inputs: Inputs) -> dict:
    """The evolve experiments' entries of report.json: Table 1, then Figures 3, 10, 5, 11."""
    campaign, loaded = inputs.campaign, inputs.loaded
    out = {"table1": table1(campaign, loaded, inputs.reruns)}
    for key, members in (("figure3", campaign.fed("figure3")),
                         ("figure10", campaign.fed("figure10"))):
        # Runs under way (read only on request) are curves so far: never a final number.
        found = groups(campaign, loaded, members, under_way=True)
        again = shown_before(campaign.figures, key) is not None
        out[key] = {"curves": curves(found, loaded.under_way),
                    "files": [] if again else inputs.save(figures.curves_figure, found, key,
                                                          TITLES[key])}
    for key, members in (("figure5", campaign.fed("figure5")),
                         ("figure11", campaign.fed("figure10"))):
        out[key] = _boxes(inputs, key, groups(campaign, loaded, members),
                          draw=shown_before(campaign.figures, key) is None)
    out["figure3"]["paper"] = paper.figure3()
    out["figure5"]["paper"] = paper.ABLATION.to_dict()
    if loaded.under_way:
        found = groups(campaign, loaded, campaign.fed("figure5"), under_way=True)
        out["figure5"]["matched"] = matched(found, loaded.under_way)
    # The paper's test asks whether the first experiment (topology + weights) is the faster.
    labels = group_labels(campaign, campaign.fed("figure5"))
    out["figure5"]["one_sided"] = {
        shape: {which: one_sided(c[which], *labels) if len(labels) == 2 else None
                for which in ("logged", "validation")}
        for shape, c in out["figure5"]["comparison"].items()}
    out["figure11"]["paper"] = paper.VELOCITY_BY_OMEGA.to_dict()
    return out


def _boxes(inputs: Inputs, key: str, found: Groups, draw: bool = True) -> dict:
    """Figure 5 or 11: the final v_x compared, logged and on the validation terrains (drawn
    unless not ``draw``: the files then are empty lists)."""
    compared = final_comparison(found, inputs.reruns)
    # Figure 5's bars also give the paper's test: one-sided, the first group (topology +
    # weights) faster than the second, as build's "one_sided" entry.
    labels = list(dict.fromkeys(g for labelled in found.values() for g in labelled))
    one_sided = tuple(labels) if key == "figure5" and len(labels) == 2 else None
    files = {}
    for which, label in (("logged", "logged best $v_x$ [m/s]"),
                         ("validation", "$v_x$ on the validation terrains [m/s]")):
        if not draw:
            files[which] = []
            continue
        panels = {shape: {g: d["values"] for g, d in c[which]["groups"].items()}
                  for shape, c in compared.items()}
        files[which] = inputs.save(figures.boxes_figure, panels, f"{key}-{which}", label,
                                   f"{TITLES[key]} ({which})", one_sided)
    return {"comparison": compared, "files": files}


def render(report: dict) -> list[str]:
    """index.md's lines of the evolve experiments: Table 1, the curves, the final v_x."""
    return _render_table1(report) + _render_curves(report) + _render_boxes(report)


def _render_table1(report: dict) -> list[str]:
    lines = [f"## {TITLES['table1']}", "",
             "Median ± sd across runs of the best individual's |V|, |E|, |G| and v_x [m/s] at "
             "generation 0 and at the last generation; the paper's row (its RQ1, 10 runs, 3000 "
             "generations) below ours, for the experiment that declares `table1`.", ""]
    rows = []
    for row in report["table1"]:
        rows.append(_table1_row(row))
        if row["paper"]:
            rows.append(_table1_paper_row(row["shape"], row["paper"]))
    header = ["experiment", "shape", "runs", "generations", "initial \\|V\\|", "initial \\|E\\|",
              "initial \\|G\\|", "initial v_x", "final \\|V\\|", "final \\|E\\|",
              "final \\|G\\|", "final v_x (logged)", "final v_x (validation)",
              "\\|G\\| increase"]
    return lines + table(header, rows)


def _table1_row(row: dict) -> list:
    i, f = row["initial"], row["final"]
    return [row["experiment"], row["shape"], f"{row['n']} of {row['tasks']}",
            number(row["generations"]["median"], 0),
            median_sd(i["nodes"], 1), median_sd(i["edges"], 1), median_sd(i["size"], 1),
            median_sd(i["velocity"]), median_sd(f["nodes"], 1), median_sd(f["edges"], 1),
            median_sd(f["size"], 1), median_sd(f["velocity"]), median_sd(row["validation"]) + (
                f" ({row['validation_non_finite']} non-finite)"
                if row["validation_non_finite"] else ""),
            number(row["size_increase"] * 100, 0) + " %"
            if row["size_increase"] == row["size_increase"] else "n/a"]


def _table1_paper_row(shape: str, p: dict) -> list:
    show = {w: {k: paper.Reported(**v).show() for k, v in p[w].items()}
            for w in ("initial", "final")}
    return ["paper", shape, "10", "3000", show["initial"]["nodes"],
            show["initial"]["edges"], show["initial"]["size"],
            show["initial"]["velocity"], show["final"]["nodes"],
            show["final"]["edges"], show["final"]["size"],
            show["final"]["velocity"], "not measured", _paper_increase(p)]


def _paper_increase(p: dict) -> str:
    """The paper's |G| increase as its Table 1 gives it (final median over initial), and the
    text's figure beside it where section 5.1 says otherwise (biped: 179.5 / 80 is +124 %,
    the text says 149 %)."""
    stated = number(p["size_increase"]["value"] * 100, 0)
    table = number((p["final"]["size"]["value"] / p["initial"]["size"]["value"] - 1) * 100, 0)
    return f"{table} %" + ("" if table == stated else f" (its text: {stated} %)")


def _render_curves(report: dict) -> list[str]:
    lines = []
    for key in ("figure3", "figure10"):
        title = TITLES[key]
        lines += [f"## {title}", ""]
        same = _one_group_shown_before(report, key)
        if same:
            lines += same
            continue
        lines += ["Median ± sd across runs (line and band); dashed with dots: the median of the "
                  "logged validation v_x, where the runs measured it.", ""]
        lines += _under_way_note(report[key]["curves"])
        if key == "figure3":
            lines += _figure3_beside_paper(report["figure3"])
        lines += images(report[key]["files"], title)
    return lines


SHOWN_BEFORE = {"figure10": "figure3", "figure11": "figure5"}
"""The figure that already shows the runs of a figure by omega when only one group feeds it."""


def shown_before(fed: dict, key: str) -> tuple[str, str] | None:
    """For Figure 10 or 11 fed (``fed``: report.json's ``figures.fed``) by one experiment that
    also feeds Figure 3 or 5 (paper-rq1's rq1): that experiment and its label, for the figure
    is the earlier one again (neither drawn nor shown); else None."""
    if key not in SHOWN_BEFORE:
        return None
    mine = fed.get("figure10", {})  # Figure 11 draws the final v_x of Figure 10's runs
    if len(mine) != 1 or not set(mine) <= set(fed.get(SHOWN_BEFORE[key], {})):
        return None
    (experiment, label), = mine.items()
    return experiment, label


def _one_group_shown_before(report: dict, key: str) -> list[str]:
    """For Figure 10 or 11 that :func:`shown_before`: the line that says so, instead of the
    figure; else nothing."""
    same = shown_before((report.get("figures") or {}).get("fed") or {}, key)
    if same is None:
        return []
    experiment, label = same
    before = TITLES[SHOWN_BEFORE[key]].split(":")[0]
    return [f"*One group only ({experiment}: {plain(label)}), whose runs {before} shows: nothing to "
            "compare by omega.*", ""]


def _under_way_note(found: dict) -> list[str]:
    """The line that says which curves are of runs still under way, and how far each got."""
    shown = {}
    for labelled in found.values():
        for c in labelled.values():
            shown.update(c.get("under_way", {}))  # absent from reports written before
    if not shown:
        return []
    runs = ", ".join(f"{task} (generation {g})" for task, g in shown.items())
    return [f"Under way, drawn to their last logged generation and in no final number: {runs}.",
            ""]


def _runs_at_the_last(c: dict) -> str:
    """How many runs the curve holds, and, where runs under way stop short of its last
    generation, how many reach it (the last medians are theirs alone)."""
    last = c["generation"][-1]
    short = sum(g < last for g in c.get("under_way", {}).values())
    return f"{len(c['runs'])} ({len(c['runs']) - short} at the last)" if short else str(
        len(c["runs"]))


def _figure3_beside_paper(data: dict) -> list[str]:
    """Figure 3's curves at their two ends, median across runs, beside what the paper says
    (v_x from section 5.1, |G| from Table 1)."""
    reported = data.get("paper")
    rows = []
    for shape, labelled in data["curves"].items():
        for group, c in labelled.items():
            if not c["generation"]:
                continue
            last_validation = (f"{number(c['validation_median'][-1])} (generation "
                               f"{number(c['validation_generation'][-1], 0)})"
                               if c["validation_median"] else "n/a")
            rows.append([shape, group, _runs_at_the_last(c), number(c["generation"][-1], 0),
                         number(c["velocity_median"][0]), number(c["velocity_median"][-1]),
                         last_validation, number(c["size_median"][0], 1),
                         number(c["size_median"][-1], 1)])
            if reported and shape in reported["size"]:
                size = reported["size"][shape]
                rows.append(["paper", "", "10", "3000",
                             paper.Reported(**reported["velocity_start"]).show(),
                             paper.Reported(**reported["velocity_end"]).show(),
                             "not measured", paper.Reported(**size["initial"]).show(),
                             paper.Reported(**size["final"]).show()])
    if not rows:
        return []
    lines = ["The curves at both ends (median across runs), the paper's row below ours "
             "(v_x: section 5.1, averaged over both shapes; |G|: Table 1):", ""]
    return lines + table(["shape", "group", "runs", "last generation", "v_x at generation 0",
                          "v_x at the last (logged)", "v_x at the last validation",
                          "\\|G\\| at generation 0", "\\|G\\| at the last"], rows)


def _render_boxes(report: dict) -> list[str]:
    lines = []
    for key in ("figure5", "figure11"):
        title = TITLES[key]
        data = report[key]
        lines += [f"## {title}", "", claim(data["paper"]), ""]
        same = _one_group_shown_before(report, key)
        if same:
            lines += same
            continue
        rows, tests = [], []
        for shape, c in data["comparison"].items():
            for group, logged in c["logged"]["groups"].items():
                validated = c["validation"]["groups"].get(group, {})
                rows.append([shape, group, logged["n"], median_sd(logged),
                             median_sd(validated)])
            tests += pair_rows(c["logged"], f"{shape}, logged")
            tests += pair_rows(c["validation"], f"{shape}, validation")
        lines += table(["shape", "group", "runs", "logged v_x", "v_x on validation terrains"],
                       rows)
        lines += tests_table(tests)
        paper_tests = [[f"{shape}, {which}", f"{t['a']} > {t['b']}", number(t["u"], 1),
                        p_noted(t)]
                       for shape, found in data.get("one_sided", {}).items()
                       for which, t in found.items() if t is not None]
        if paper_tests:
            lines += ["The paper's own test, one-sided:", ""]
            lines += table(["sample", "alternative", "U", "p (one-sided)"], paper_tests)
        lines += _matched_table(data.get("matched") or {})
        lines += images_of([(data["files"]["logged"], title + " (logged)"),
                            (data["files"]["validation"], title + " (validation)")])
    return lines


def _matched_table(found: dict) -> list[str]:
    """Figure 5 so far (an interim report): the groups at the same generation."""
    rows = [[shape, number(m["generation"], 0), group, len(g["runs"]),
             ", ".join(g["under_way"]) or "none", number(g["logged"]), number(g["validation"])]
            for shape, m in found.items() for group, g in m["groups"].items()]
    if not rows:
        return []
    return ["So far, at the same budget: each shape's groups at the furthest generation all of "
            "them have validated, medians across the runs that reached it, runs under way "
            "among them (nothing tested):", ""] + table(
        ["shape", "generation", "group", "runs", "under way", "logged v_x",
         "v_x on validation terrains"], rows)


SECTION = Section(build, render)
"""The evolve experiments' part of the report."""

__all__ = ["SECTION", "TITLES", "build", "compare", "curves", "final_comparison", "groups",
           "matched", "one_sided", "render", "shape_order", "table1", "task_shape"]
