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
from ..viz.plots import curve
from . import paper
from .campaign import CampaignFolder, Task
from .load import Loaded, shape_name

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


def groups(campaign: CampaignFolder, loaded: Loaded, members: dict[str, str]) -> Groups:
    """The finished runs of the experiments ``members`` (id -> label), per shape and label."""
    found: dict[str, dict[str, dict[str, RunLog]]] = {}
    for experiment, label in members.items():
        for task in campaign.of(experiment, "evolve"):
            if task.id in loaded.runs:
                shape = task_shape(task, loaded)
                found.setdefault(shape, {}).setdefault(label, {})[task.id] = loaded.runs[task.id]
    return {s: {label: found[s][label] for label in members.values() if label in found[s]}
            for s in shape_order(found)}


def _column(runs: dict[str, RunLog], column: str, row: int) -> list[float]:
    return [float(run.log[column][row]) for run in runs.values()]


def table1(campaign: CampaignFolder, loaded: Loaded, reruns: dict[str, dict]) -> list[dict]:
    """One row per evolve experiment and shape: initial and final |V|, |E|, |G| and v_x of
    the best (median, sd, ...), its v_x on the validation terrains, the paper's numbers."""
    rows = []
    for experiment in campaign.experiments:
        tasks = campaign.of(experiment, "evolve")
        by_shape: dict[str, list[Task]] = {}
        for task in tasks:
            by_shape.setdefault(task_shape(task, loaded), []).append(task)
        for shape in shape_order(by_shape):
            runs = {t.id: loaded.runs[t.id] for t in by_shape[shape] if t.id in loaded.runs}
            row = {
                "experiment": experiment, "shape": shape, "tasks": len(by_shape[shape]),
                "n": len(runs), "missing": [t.id for t in by_shape[shape] if t.id not in runs],
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
            beside = experiment in campaign.fed("table1")
            row["paper"] = _paper_table1(shape) if beside else None
            rows.append(row)
    return rows


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


def curves(found: Groups) -> dict:
    """Per shape and group: median and sd across runs, per generation, of the best's v_x and
    |G|, and the median of the logged validation v_x where it was measured."""
    out = {}
    for shape, labelled in found.items():
        out[shape] = {}
        for label, runs in labelled.items():
            generation, v_median, v_sd = curve(list(runs.values()), "best_velocity")
            _, g_median, g_sd = curve(list(runs.values()), "best_size")
            x, validation, _ = curve(list(runs.values()), "validation_velocity")
            shown = np.isfinite(validation)
            out[shape][label] = {
                "runs": list(runs), "generation": generation.tolist(),
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


__all__ = ["compare", "curves", "final_comparison", "groups",
           "one_sided", "shape_order", "table1", "task_shape"]
