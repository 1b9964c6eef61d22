"""Beyond the paper: the cut ratios (eta) of the best during evolution, by omega.

Figure 9 measures eta on the final bests, once they are taken apart for reassembly. The same
cut can be made on the best of any generation: each run's ``bests.jsonl`` holds it, so each
run of the experiments that feed Figure 10 (the omega variants) is cut along the partition it
evolved with (its ``modules``, the paper's: the one its reassembly cuts along) every
``validate_every`` generations, where it also measured its validation v_x. That shows when a
variant's controllers become modular, and an interim report (``--under-way``) can compare the
variants at the same budget long before their runs finish. eta_num is the share of the best's
edges that cross modules, eta_weight the same share of sum(|w| + |b|) (one donor: the
authors' count, :func:`somite.modules.module.cut`). A line a pack thinned has no genome and is
no sample; a run is never simulated here.
"""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np

from ..analysis.stats import RunLog
from ..brain.genome import Genome
from ..errors import SomiteError
from ..modules.module import cut
from ..sim.body import Shape
from ..sim.partition import Partition
from ..viz import report_figures as figures
from .evolution import compare, groups, same_budget
from .section import Inputs, Section
from .text import images_of, median_sd, number, pair_rows, plain, table, tests_table

KEY = "cuts_during_evolution"
"""Its entry of report.json."""

TITLE = "Beyond the paper: eta of the best during evolution, by omega"

COLUMNS = ("eta_num", "eta_weight")

_GENERATION = re.compile(rb'\{"generation":(0|[1-9][0-9]{0,17}),"velocity":')
"""The start of a line of ``bests.jsonl`` that holds a genome (a thinned line does not)."""


def sampled_bests(path: Path, every: int, last: int | None = None) -> dict[int, Genome]:
    """The best genomes of ``bests.jsonl`` at ``path`` of the generations divisible by
    ``every``, and of generation ``last`` (a finished run's end); a thinned line, a line a
    run under way is still writing and one that is not a genome are skipped (no sample, never
    an error: the run's own checks judge its files)."""
    out: dict[int, Genome] = {}
    try:
        handle = open(path, "rb")
    except OSError:
        return out
    with handle:
        for line in handle:
            found = _GENERATION.match(line)
            if found is None or not line.endswith(b"\n"):
                continue
            if int(found[1]) % every and int(found[1]) != last:
                continue
            try:
                out[int(found[1])] = Genome.from_dict(json.loads(line)["genome"])
            except (ValueError, KeyError, TypeError, SomiteError):
                continue
    return out


def partition_of(run: RunLog) -> Partition | None:
    """The partition ``run`` evolved with (its ``modules``; omega 1 ignores it but its
    reassembly cuts along it); None where its shape has none."""
    try:
        return Partition.parse(str(run.config.get("modules") or "paper"),
                               Shape.parse(run.config["shape"]))
    except (SomiteError, KeyError, TypeError):
        return None


def cut_series(run: RunLog, finished: bool = True) -> RunLog | None:
    """``run``'s best cut every ``validate_every`` generations and, ``finished``, at its
    last (a run under way ends at its last sampled one: its curve takes no odd step). A RunLog
    whose log holds ``generation``, ``eta_num``, ``eta_weight`` and, from the run's log at the
    same generations, ``best_size``, ``best_velocity`` and ``validation_velocity`` (NaN where
    the log has none); None where the run has no partition or no sample."""
    partition = partition_of(run)
    every = run.config.get("validate_every")
    if partition is None or not isinstance(every, int) or every < 1:
        return None
    last = int(run.log["generation"][-1]) if finished and len(run.log["generation"]) else None
    bests = sampled_bests(run.path / "bests.jsonl", every, last)
    rows = _rows(run)
    kept = sorted(g for g in bests if g in rows)
    if not kept:
        return None
    ratios = [cut(bests[g], partition).total for g in kept]
    log = {"generation": np.array(kept, dtype=float),
           "eta_num": np.array([r.eta_num for r in ratios]),
           "eta_weight": np.array([r.eta_weight for r in ratios])}
    for column in ("best_size", "best_velocity", "validation_velocity"):
        logged = run.log.get(column)
        log[column] = np.array([np.nan if logged is None else logged[rows[g]] for g in kept],
                               dtype=float)
    return RunLog(run.path, run.config, log)


def curves(series: dict) -> dict:
    """Per shape and group: median and sd across runs of eta_num and eta_weight per sampled
    generation (each generation over the runs that reached it)."""
    from ..viz.plots import curve

    out: dict = {}
    for shape, labelled in series.items():
        out[shape] = {}
        for label, runs in labelled.items():
            entry: dict = {"runs": list(runs)}
            for column in COLUMNS:
                x, median, sd = curve(list(runs.values()), column)
                entry["generation"] = x.tolist()
                entry[f"{column}_median"] = median.tolist()
                entry[f"{column}_sd"] = sd.tolist()
            out[shape][label] = entry
    return out


def matched(series: dict, under_way: set[str]) -> dict:
    """The groups so far, at the same budget: per shape with two groups or more, the furthest
    sampled generation every group reached, and per group the medians there, across the runs
    that reached it, of eta_num, eta_weight, |G|, the logged best v_x and its validation v_x.
    Nothing is tested (the final comparison does that); a shape is left out where that
    generation is 0 or its compared runs have all finished."""
    out = {}
    for shape, labelled in series.items():
        same = same_budget(labelled, _rows, under_way)
        if same is None:
            continue
        generation, at = same
        out[shape] = {"generation": generation, "groups": {}}
        for label, rows in at.items():
            group = labelled[label]
            with warnings.catch_warnings():  # a column of NaN only (no edge) is NaN, quietly
                warnings.simplefilter("ignore", RuntimeWarning)
                values = {column: float(np.nanmedian([group[t].log[column][k]
                                                      for t, k in rows.items()]))
                          for column in (*COLUMNS, "best_size", "best_velocity",
                                         "validation_velocity")}
            out[shape]["groups"][label] = {"runs": list(rows),
                                           "under_way": [t for t in rows if t in under_way],
                                           **values}
    return out


def _rows(run: RunLog) -> dict[int, int]:
    """Every generation of a run's log (or of a cut series) -> its row."""
    return {int(g): k for k, g in enumerate(run.log["generation"])}


def finals(series: dict, finished: set[str]) -> dict:
    """Per shape: each group's finished runs' eta of their last best, compared pairwise."""
    out = {}
    for shape, labelled in series.items():
        done = {label: {t: run for t, run in runs.items() if t in finished}
                for label, runs in labelled.items()}
        done = {label: runs for label, runs in done.items() if runs}
        if not done:
            continue
        ids = {label: list(runs) for label, runs in done.items()}
        out[shape] = {column: compare({label: [float(run.log[column][-1])
                                               for run in runs.values()]
                                       for label, runs in done.items()}, ids)
                      for column in COLUMNS}
    return out


def build(inputs: Inputs) -> dict:
    """The entry of report.json (none where no experiment feeds Figure 10): the curves, the
    groups at the same budget (an interim report), the finished runs' last bests compared,
    and the figure."""
    members = inputs.campaign.fed("figure10")
    if not members:
        return {}
    found = groups(inputs.campaign, inputs.loaded, members, under_way=True)
    series: dict = {}
    without: list[str] = []
    for shape, labelled in found.items():
        for label, runs in labelled.items():
            for task, run in runs.items():
                cuts = cut_series(run, finished=task in inputs.loaded.runs)
                if cuts is None:
                    without.append(task)
                else:
                    series.setdefault(shape, {}).setdefault(label, {})[task] = cuts
    under_way = set(inputs.loaded.under_way)
    drawn = {shape: {label: list(runs.values()) for label, runs in labelled.items()}
             for shape, labelled in series.items()}
    return {KEY: {
        "every": {task: int(run.config["validate_every"]) for labelled in series.values()
                  for runs in labelled.values() for task, run in runs.items()},
        "curves": curves(series),
        "under_way": {task: int(run.log["generation"][-1]) for labelled in series.values()
                      for runs in labelled.values() for task, run in runs.items()
                      if task in under_way},
        "without": without,
        "matched": matched(series, under_way),
        "final": finals(series, set(inputs.loaded.runs)),
        "files": inputs.save(figures.cut_curves_figure, drawn, "cuts-during-evolution", TITLE),
    }}


def render(report: dict) -> list[str]:
    """index.md's lines; none for a report without the entry (a campaign that feeds no
    Figure 10, or a report.json written before it existed)."""
    data = report.get(KEY)
    if data is None:
        return []
    every = sorted(set(data["every"].values()))
    lines = [f"## {TITLE}", "",
             "Figure 9 cuts the final bests; here each run's best is cut along the partition it "
             "evolved with (the paper's, the one its reassembly cuts along) every "
             f"{', '.join(map(str, every)) or 'n/a'} generations, from its `bests.jsonl`: "
             "eta_num is the share of its edges that cross modules, eta_weight the same share "
             "of sum(|w| + |b|). Median ± sd across runs (line and band), each "
             "generation over the runs that reached it.", ""]
    if data["under_way"]:
        runs = ", ".join(f"{plain(t)} (generation {g})" for t, g in data["under_way"].items())
        lines += [f"Under way, drawn to their last sampled generation: {runs}.", ""]
    if data["without"]:
        lines += [f"No cut (no partition or no sampled best): "
                  f"{', '.join(plain(t) for t in data['without'])}.", ""]
    rows, tests = [], []
    for shape, compared in data["final"].items():
        for group, num in compared["eta_num"]["groups"].items():
            weight = compared["eta_weight"]["groups"][group]
            rows.append([shape, group, num["n"], median_sd(num), median_sd(weight)])
        for column in COLUMNS:
            tests += pair_rows(compared[column], f"{shape}, {column}")
    if rows:
        lines += ["The finished runs' last bests:", ""]
        lines += table(["shape", "group", "runs", "eta_num", "eta_weight"], rows)
        lines += tests_table(tests)
    lines += _matched_table(data["matched"])
    return lines + images_of([(data["files"], TITLE)])


def _matched_table(found: dict) -> list[str]:
    rows = [[shape, number(m["generation"], 0), group, len(g["runs"]),
             ", ".join(g["under_way"]) or "none", number(g["eta_num"]),
             number(g["eta_weight"]), number(g["best_size"], 1), number(g["best_velocity"]),
             number(g["validation_velocity"])]
            for shape, m in found.items() for group, g in m["groups"].items()]
    if not rows:
        return []
    return ["So far, at the same budget: each shape's groups at the furthest sampled "
            "generation all of them reached, medians across the runs that reached it, runs "
            "under way among them (nothing tested):", ""] + table(
        ["shape", "generation", "group", "runs", "under way", "eta_num", "eta_weight",
         "\\|G\\|", "logged v_x", "v_x on validation terrains"], rows)


SECTION = Section(build, render)
"""The cuts during evolution: fed by the evolve experiments of Figure 10, after their
figures."""

__all__ = ["KEY", "SECTION", "TITLE", "cut_series", "finals", "matched", "partition_of",
           "sampled_bests"]
