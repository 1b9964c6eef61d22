"""The lengths of the final bests' edges (issue 72: the ``lengths`` campaign's third column,
beside v_x and |G| of Figure 3 and rho of Figure 7).

An edge's length is the distance between the centres of the voxels of its two nodes, in voxel
sides, to 3 decimals (:func:`somite.brain.delays.length_counts`): 0 for two nodes of one voxel,
1 for side neighbours, 1.414 for diagonal ones. Per shape and group of the experiments that
declare ``edge-lengths`` (``campaign.fed("edge-lengths")``; a variant is a group of its own),
the edges of the finished runs' final bests (``best.json``) are counted per length, pooled over
the seeds; each run's mean length is also compared between the groups. A run not finished
(under way, or missing) is in no number here. A campaign that declares none gets no entry.
"""

from __future__ import annotations

import numpy as np

from .._io import csv_text, write_atomic
from ..analysis.stats import describe
from ..brain.delays import edge_lengths, length_counts
from ..viz import report_figures as figures
from .evolution import compare, group_label, group_labels, shape_order, task_shape
from .section import Inputs, Section
from .text import (
    FIGURES,
    images,
    median_sd,
    number,
    pair_rows,
    plain,
    table,
    tests_table,
)

FIGURE = "edge-lengths"
"""The figure's name where an experiment declares it."""

KEY = "edge_lengths"
"""Its entry of report.json."""

TITLE = "Beyond the paper: the lengths of the final bests' edges"

CSV = "edge-lengths.csv"
"""The counts per run and length, in the report's ``figures/``."""

CSV_COLUMNS = ("shape", "group", "experiment", "task", "length_voxels", "edges")

DIGITS = 3
"""Lengths are counted to 3 decimals of a voxel side, as :func:`length_counts` counts them."""


def final_bests(campaign, loaded, members: dict[str, str]) -> tuple[dict, dict[str, str]]:
    """shape -> group -> task id -> its final best (None: not finished, or unreadable), for
    every evolve task of the experiments ``members`` (id -> label), in the campaign's order;
    and group -> its experiment."""
    found: dict[str, dict[str, dict]] = {}
    experiments: dict[str, str] = {}
    for experiment, label in members.items():
        for task in campaign.of(experiment, "evolve"):
            group = group_label(label, task.variant)
            experiments[group] = experiment
            found.setdefault(task_shape(task, loaded), {}).setdefault(group, {})[task.id] = \
                loaded.bests.get(task.id)
    order = group_labels(campaign, members)
    return {shape: {group: found[shape][group] for group in order if group in found[shape]}
            for shape in shape_order(found)}, experiments


def _run(genome) -> dict:
    """One final best's edges: how many of each length, and their mean length."""
    counts = length_counts([genome])
    lengths = edge_lengths(genome)
    return {"lengths": list(counts), "counts": list(counts.values()),
            "edges": int(len(lengths)),
            "mean": float(lengths.mean()) if len(lengths) else None}


def _share(counts: dict[float, int], edges: int, keep) -> float | None:
    if not edges:
        return None
    return sum(c for length, c in counts.items() if keep(length)) / edges


def group_entry(genomes: dict, experiment: str) -> dict:
    """A group's numbers from its task ids -> final bests (None where not finished)."""
    runs = {task: _run(g) for task, g in genomes.items() if g is not None}
    finished = [g for g in genomes.values() if g is not None]
    counts = length_counts(finished)
    edges = sum(counts.values())
    lengths = np.concatenate([edge_lengths(g) for g in finished] or [np.zeros(0)])
    means = [r["mean"] for r in runs.values() if r["mean"] is not None]
    return {
        "experiment": experiment, "tasks": len(genomes), "runs": list(runs),
        "missing": [task for task, g in genomes.items() if g is None],
        "edges": edges, "lengths": list(counts), "counts": list(counts.values()),
        "shares": [c / edges for c in counts.values()],
        "mean": float(lengths.mean()) if edges else None,
        "run_mean": describe(means),
        # 0 and 1 are exact: two nodes of one voxel, or of two side neighbours.
        "inside_voxel": _share(counts, edges, lambda d: d == 0.0),
        "side_neighbour": _share(counts, edges, lambda d: d == 1.0),
        "longer": _share(counts, edges, lambda d: d > 1.0),
        "per_run": runs,
    }


def build(inputs: Inputs) -> dict:
    """The ``edge_lengths`` entry of report.json (none where no experiment declares it): per
    shape and group the counts, shares and means, per shape the groups' run means compared,
    the figure and the CSV."""
    members = inputs.campaign.fed(FIGURE)
    if not members:
        return {}
    found, experiments = final_bests(inputs.campaign, inputs.loaded, members)
    shapes = {shape: {group: group_entry(genomes, experiments[group])
                      for group, genomes in groups.items()}
              for shape, groups in found.items()}
    tests = {shape: _run_means_compared(groups) for shape, groups in shapes.items()}
    drawn = {shape: {g: e for g, e in groups.items() if e["edges"]}
             for shape, groups in shapes.items()}
    drawn = {shape: groups for shape, groups in drawn.items() if groups}
    files = inputs.save(figures.edge_lengths_figure, drawn, FIGURE, TITLE)
    rows = csv_rows(shapes)
    if rows:
        write_atomic(inputs.folder / CSV, csv_text(CSV_COLUMNS, rows))
    return {KEY: {"shapes": shapes, "run_mean_tests": tests, "files": files,
                  "csv": CSV if rows else None}}


def _run_means_compared(groups: dict) -> list[dict]:
    """The pairwise tests of the runs' mean edge lengths between a shape's groups that have
    a run with edges (a group of none is no sample: its tests would be empty rows)."""
    means = {g: {t: r["mean"] for t, r in e["per_run"].items() if r["mean"] is not None}
             for g, e in groups.items()}
    means = {g: found for g, found in means.items() if found}
    return compare({g: list(found.values()) for g, found in means.items()},
                   {g: list(found) for g, found in means.items()})["tests"]


def csv_rows(shapes: dict) -> list[list]:
    """The CSV's rows: one per shape, group, run and length its final best has edges of."""
    return [[shape, group, entry["experiment"], task, f"{length:.{DIGITS}f}", count]
            for shape, groups in shapes.items() for group, entry in groups.items()
            for task, run in entry["per_run"].items()
            for length, count in zip(run["lengths"], run["counts"])]


def render(report: dict) -> list[str]:
    """index.md's lines of the edge lengths; none for a report without them (a campaign that
    does not declare them, or a report.json written before they existed)."""
    data = report.get(KEY)
    if data is None:
        return []
    lines = [f"## {TITLE}", "",
             "An edge's length is the distance between the centres of the voxels of its two "
             "nodes, in voxel sides, to 3 decimals: 0 for two nodes of one voxel, 1 for side "
             "neighbours, 1.414 for diagonal ones (`somite.brain.delays.length_counts`). The "
             "edges of each group's final bests (its finished runs' `best.json`) are pooled "
             "over the seeds; a run not finished is in no number here. Mean length: over the "
             "pooled edges; a run's mean: median ± sd across the runs.", ""]
    rows = []
    for shape, groups in data["shapes"].items():
        for group, e in groups.items():
            rows.append([shape, group, f"{len(e['runs'])} of {e['tasks']}", e["edges"],
                         number(e["mean"]), median_sd(e["run_mean"]),
                         _percent(e["inside_voxel"]), _percent(e["side_neighbour"]),
                         _percent(e["longer"])])
    lines += table(["shape", "group", "runs", "edges", "mean length [voxels]",
                    "a run's mean length", "inside a voxel (0)", "to a side neighbour (1)",
                    "longer (> 1)"], rows)
    tests = [row for shape, found in data["run_mean_tests"].items()
             for row in pair_rows({"tests": found}, shape)]
    lines += ["A run's mean edge length, compared:", ""] + tests_table(tests, "shape")
    for shape, groups in data["shapes"].items():
        lines += _counts_table(shape, groups)
    lines += images(data["files"], TITLE)
    if data.get("csv"):
        lines += [f"Edges per run and length: [CSV]({FIGURES}/{data['csv']}) "
                  f"(columns {', '.join(CSV_COLUMNS)}).", ""]
    return lines


def _counts_table(shape: str, groups: dict) -> list[str]:
    """One shape's edges per length (rows) and group (columns): count and share."""
    lengths = sorted({d for e in groups.values() for d in e["lengths"]})
    if not lengths:
        return []
    rows = []
    for length in lengths:
        row = [f"{length:.{DIGITS}f}"]
        for e in groups.values():
            found = dict(zip(e["lengths"], e["counts"]))
            count = found.get(length, 0)
            row.append(f"{count} ({_percent(count / e['edges'])})" if e["edges"] else "n/a")
        rows.append(row)
    return [f"{shape}: edges of each length (count, share of the group's edges):", ""] + table(
        ["length [voxels]", *(plain(group) for group in groups)], rows)


def _percent(share) -> str:
    return "n/a" if share is None else f"{100 * share:.1f} %"


SECTION = Section(build, render)
"""The edge lengths' part of the report: fed by evolve experiments, after their figures."""

__all__ = ["CSV", "CSV_COLUMNS", "FIGURE", "KEY", "SECTION", "TITLE", "build",
           "csv_rows", "final_bests", "group_entry", "render"]
