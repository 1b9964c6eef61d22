"""``somite report``: a campaign directory in, a report folder out.

REPORT holds ``index.md`` (and ``index.html``), ``report.json`` (every number of the report),
``figures/`` (PNG and SVG, time-lapse strips as PNG) and ``cache/`` (the validation and fresh
re-runs and the strips already drawn, so that a second report on the same campaign is quick).
The report is written all or nothing (:mod:`.staging`): a failure leaves the old one as it
was. A task that is not finished, or cannot be read, is listed as missing. Each kind of
experiment adds its own entries, figures and text through its section (:mod:`.sections`), in the
kinds' order.
"""

from __future__ import annotations

import math
from pathlib import Path

from .._io import check_output_folder, write_atomic
from ..analysis.stats import describe, to_json
from ..errors import bad
from ..formats import REPORT
from ..limits import MAX_VALIDATION, at_most
from ..tasks.validation import (
    VALIDATION_COUNT,
    check_count,
    fresh_terrains,
    validation_terrains,
)
from ..viz import report_figures as figures
from . import evolution, paper
from .campaign import read_campaign
from .caveats import caveats
from .load import load, shape_name
from .markdown import render_html, render_markdown
from .rerun import FRESH_COUNT, FRESH_NOISE_SEED, rerun_finals
from .section import Inputs, add_entries
from .sections import SECTIONS, in_order
from .staging import staged_report
from .timelapse import draw_strips
from .transfer import read_transfer


def build_report(campaign_dir: str | Path, out: str | Path, validation: int = VALIDATION_COUNT,
                 timelapse: bool = True, stage=None, under_way: bool = False,
                 fresh: int = FRESH_COUNT) -> dict:
    """Write the report of ``campaign_dir`` into ``out``; returns report.json's data.
    ``stage(text)``, when given, is told what is being done (it takes seconds to minutes).
    With ``under_way``, the evolve runs not finished yet are drawn in the curves (Figures 3
    and 10) to their last logged generation, and in no final number. ``fresh``: how many
    fresh terrains each final best is also re-run on (0: none)."""
    stage = stage or (lambda text: None)
    check_count(validation)
    if isinstance(fresh, bool) or not isinstance(fresh, int) or fresh < 0:
        raise bad("fresh", fresh, "must be a whole number (0: no fresh terrains)")
    at_most("fresh", fresh, MAX_VALIDATION)
    out = check_output_folder(out)
    stage("reading the campaign")
    campaign = read_campaign(campaign_dir)
    check_apart(campaign_dir, out)
    loaded = load(campaign, under_way)
    with staged_report(out) as new:
        report = _write_report(campaign, loaded, new, validation, timelapse, stage, fresh)
    return report


def _write_report(campaign, loaded, new: Path, validation: int, timelapse: bool,
                  stage, fresh: int) -> dict:
    """Every file of the report, into the (hidden, new) report folder ``new``."""
    folder = new / "figures"
    folder.mkdir(exist_ok=True)
    stage(f"re-running the final bests on {validation} validation terrains")
    reruns, simulated = rerun_finals(loaded.runs, loaded.bests, loaded.sims,
                                     validation_terrains(validation),
                                     new / "cache" / "validation.json")
    drawn_fresh = {}
    if fresh:
        stage(f"re-running the final bests on {fresh} fresh terrains")
        drawn_fresh, more = rerun_finals(loaded.runs, loaded.bests, loaded.sims,
                                         fresh_terrains(fresh), new / "cache" / "fresh.json",
                                         FRESH_NOISE_SEED)
        simulated += more
    rows = _validation_rows(campaign, loaded, reruns, drawn_fresh)
    report = {
        **REPORT.header(),
        "campaign": {"name": campaign.name, "source": campaign.source,
                     "directory": str(campaign.root), "experiments": campaign.experiments,
                     "kinds": [kind for kind in SECTIONS if campaign.of_kind(kind)]},
        "caveats": None,  # filled last, from the numbers below; kept first in report.json
        "status": {"experiments": campaign.status(loaded.broken), "unreadable": loaded.broken,
                   "under_way": _under_way(loaded)},
        "figures": {"fed": campaign.figures, "missing": campaign.missing_figures(),
                    "declared": campaign.declared},
    }
    stage("drawing the figures")
    inputs = Inputs(campaign, loaded, reruns, folder)
    for section in in_order():
        add_entries(report, section.build(inputs))
    report["validation"] = _validation(rows, validation, inputs)
    report["transfer"] = read_transfer(campaign.root, {
        t.id: (t.experiment, evolution.task_shape(t, loaded)) for t in campaign.tasks
        if t.kind == "evolve" and t.id in loaded.runs})
    stage("drawing the time-lapses")
    strips, current, drawn = draw_strips(rows, loaded, folder,
                                         new / "cache" / "timelapse.json") \
        if timelapse else ([], {}, 0)
    report["timelapse"] = strips
    for task, strip in current.items():
        report["status"]["under_way"][task]["strip"] = strip
    report["cache"] = {"genomes_simulated": simulated, "strips_drawn": drawn}
    report["paper"] = paper.everything()
    report["caveats"] = caveats(campaign, loaded.runs, report)
    write_atomic(new / "report.json", to_json(report))
    text = render_markdown(report)
    write_atomic(new / "index.md", text)
    html = render_html(text, campaign.name)
    if html is not None:
        write_atomic(new / "index.html", html)
    return report


def check_apart(campaign_dir: str | Path, out: str | Path) -> None:
    """Refuse a report folder ``out`` that is the campaign folder or inside it (the report
    would write over a task's files: a reassembly's report.json), or one whose ``figures/``
    or ``cache/`` holds the campaign folder; both paths resolved, symbolic links followed."""
    from ..errors import bad

    campaign = Path(campaign_dir).resolve()
    folder = Path(out).resolve()
    if folder == campaign or campaign in folder.parents:
        raise bad("out", str(out), f"is the campaign folder {campaign_dir} or inside it (the "
                  "report would write over its files); give a report folder outside it")
    for name in ("figures", "cache"):
        mine = folder / name
        if campaign == mine or mine in campaign.parents:
            raise bad("out", str(out), f"holds the campaign folder {campaign_dir} in its "
                      f"{name}/, which the report writes; give another report folder")


def _validation_rows(campaign, loaded, reruns: dict, fresh: dict) -> list[dict]:
    """Per final best: its logged v_x, its re-runs on the validation terrains and, where
    ``fresh`` holds them, on the fresh terrains (``fresh``, ``fresh_terrains``,
    ``fresh_velocities``: absent from reports written without)."""
    rows = []
    for task in campaign.tasks:
        if task.id in reruns:
            result = reruns[task.id]
            rows.append({"task": task.id, "experiment": task.experiment, "kind": task.kind,
                         "shape": shape_name(loaded.runs[task.id].config["shape"]),
                         "logged": result["logged"], "validation": result["mean"],
                         "logged_validation": result["logged_validation"],
                         "logged_over_validation": logged_over_validation(result["logged"],
                                                                          result["mean"]),
                         "terrains": result["terrains"], "velocities": result["velocities"]})
            if task.id in fresh:
                drawn = fresh[task.id]
                rows[-1].update({"fresh": drawn["mean"], "fresh_terrains": drawn["terrains"],
                                 "fresh_velocities": drawn["velocities"],
                                 "fresh_noise_seed": FRESH_NOISE_SEED})
    # Grouped by experiment (the campaign's order), then shape (biped, worm, others).
    experiments = list(dict.fromkeys(r["experiment"] for r in rows))
    shapes = evolution.shape_order(r["shape"] for r in rows)
    return sorted(rows, key=lambda r: (experiments.index(r["experiment"]),
                                       shapes.index(r["shape"])))


def logged_over_validation(logged: float, validation: float) -> float | None:
    """How many times its validation v_x a final best's logged v_x is: above 1 by the luck of
    its training draw. None where the validation v_x is not positive and finite: against a
    robot that stands still or goes back it measures nothing."""
    if not (math.isfinite(validation) and validation > 0 and math.isfinite(logged)):
        return None
    return logged / validation


def _under_way(loaded) -> dict:
    """Each run under way that the report drew: the last generation it logged, of how many."""
    return {task: {"generation": int(run.log["generation"][-1]),
                   "generations": run.config.get("generations")}
            for task, run in loaded.under_way.items()}


def _validation(rows: list[dict], n_terrains: int, inputs: Inputs) -> dict:
    summary = {}
    for row in rows:
        group = summary.setdefault(f"{row['experiment']}, {row['shape']}", [])
        group.append(row)
    table = []
    for name, members in summary.items():
        logged = describe([m["logged"] for m in members])
        finite = [m["validation"] for m in members if math.isfinite(m["validation"])]
        table.append({"group": name, "experiment": members[0]["experiment"],
                      "shape": members[0]["shape"], "n": len(members),
                      "logged": logged, "validation": describe(finite),
                      "validation_non_finite": len(members) - len(finite)})
        if all("fresh" in m for m in members):
            drawn = [m["fresh"] for m in members if math.isfinite(m["fresh"])]
            table[-1].update({"fresh": describe(drawn),
                              "fresh_non_finite": len(members) - len(drawn)})
    files = inputs.save(figures.validation_figure, rows, "validation")
    return {"terrains": n_terrains, "robots": rows, "summary": table, "files": files}


__all__ = ["build_report", "logged_over_validation"]
