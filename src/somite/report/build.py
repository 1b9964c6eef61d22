"""``somite report``: a campaign directory in, a report folder out.

REPORT holds ``index.md`` (and ``index.html``), ``report.json`` (every number of the report),
``figures/`` (PNG and SVG, time-lapse strips as PNG) and ``cache/`` (the validation re-runs and
the strips already drawn, so that a second report on the same campaign is quick). The report
is written all or nothing (:mod:`.staging`): a failure leaves the old one as it was. A task
that is not finished, or cannot be read, is listed as missing.
"""

from __future__ import annotations

import math
from pathlib import Path

from .._io import check_output_folder, write_atomic
from ..analysis.stats import describe, to_json
from ..formats import REPORT
from ..tasks.validation import VALIDATION_COUNT, check_count
from ..viz import report_figures as figures
from . import evolution, paper, reassembly
from .campaign import read_campaign
from .caveats import caveats
from .discovery import discovery_rows, discovery_summary
from .load import load, shape_name
from .markdown import render_html, render_markdown
from .rerun import rerun_finals
from .sections import TITLES
from .staging import staged_report
from .timelapse import draw_strips
from .transfer import read_transfer


def build_report(campaign_dir: str | Path, out: str | Path, validation: int = VALIDATION_COUNT,
                 timelapse: bool = True, stage=None) -> dict:
    """Write the report of ``campaign_dir`` into ``out``; returns report.json's data.
    ``stage(text)``, when given, is told what is being done (it takes seconds to minutes)."""
    stage = stage or (lambda text: None)
    check_count(validation)
    out = check_output_folder(out)
    stage("reading the campaign")
    campaign = read_campaign(campaign_dir)
    check_apart(campaign_dir, out)
    loaded = load(campaign)
    with staged_report(out) as new:
        report = _write_report(campaign, loaded, new, validation, timelapse, stage)
    return report


def _write_report(campaign, loaded, new: Path, validation: int, timelapse: bool,
                  stage) -> dict:
    """Every file of the report, into the (hidden, new) report folder ``new``."""
    folder = new / "figures"
    folder.mkdir(exist_ok=True)
    stage(f"re-running the final bests on {validation} validation terrains")
    reruns, simulated = rerun_finals(loaded.runs, loaded.bests, loaded.sims, validation,
                                     new / "cache" / "validation.json")
    rows = _validation_rows(campaign, loaded, reruns)
    report = {
        **REPORT.header(),
        "campaign": {"name": campaign.name, "source": campaign.source,
                     "directory": str(campaign.root), "experiments": campaign.experiments},
        "caveats": None,  # filled last, from the numbers below; kept first in report.json
        "status": {"experiments": campaign.status(loaded.broken), "unreadable": loaded.broken},
        "figures": {"fed": campaign.figures, "missing": campaign.missing_figures()},
        "table1": evolution.table1(campaign, loaded, reruns),
    }
    stage("drawing the figures")
    report.update(_evolution_figures(campaign, loaded, reruns, folder))
    report.update(_reassembly_figures(campaign, loaded, folder))
    report["discovery"] = _discovery(campaign, loaded, folder)
    report["validation"] = _validation(rows, validation, folder)
    report["transfer"] = read_transfer(campaign.root, {
        t.id: (t.experiment, evolution.task_shape(t, loaded)) for t in campaign.tasks
        if t.kind == "evolve" and t.id in loaded.runs})
    stage("drawing the time-lapses")
    strips, drawn = draw_strips(rows, loaded, folder, new / "cache" / "timelapse.json") \
        if timelapse else ([], 0)
    report["timelapse"] = strips
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


def _validation_rows(campaign, loaded, reruns: dict) -> list[dict]:
    rows = []
    for task in campaign.tasks:
        if task.id in reruns:
            result = reruns[task.id]
            rows.append({"task": task.id, "experiment": task.experiment, "kind": task.kind,
                         "shape": shape_name(loaded.runs[task.id].config["shape"]),
                         "logged": result["logged"], "validation": result["mean"],
                         "logged_validation": result["logged_validation"],
                         "terrains": result["terrains"], "velocities": result["velocities"]})
    # Grouped by experiment (the campaign's order), then shape (biped, worm, others).
    experiments = list(dict.fromkeys(r["experiment"] for r in rows))
    shapes = evolution.shape_order(r["shape"] for r in rows)
    return sorted(rows, key=lambda r: (experiments.index(r["experiment"]),
                                       shapes.index(r["shape"])))


def _evolution_figures(campaign, loaded, reruns: dict, folder: Path) -> dict:
    out = {}
    for key, members in (("figure3", campaign.fed("figure3")),
                         ("figure10", campaign.fed("figure10"))):
        found = evolution.groups(campaign, loaded, members)
        out[key] = {"curves": evolution.curves(found),
                    "files": _save(figures.curves_figure, found, folder, key, TITLES[key])}
    for key, members in (("figure5", campaign.fed("figure5")),
                         ("figure11", campaign.fed("figure10"))):
        title = TITLES[key]
        found = evolution.groups(campaign, loaded, members)
        compared = evolution.final_comparison(found, reruns)
        files = {}
        for which, label in (("logged", "logged best $v_x$ [m/s]"),
                             ("validation", "$v_x$ on the validation terrains [m/s]")):
            panels = {shape: {g: d["values"] for g, d in c[which]["groups"].items()}
                      for shape, c in compared.items()}
            files[which] = _save(figures.boxes_figure, panels, folder, f"{key}-{which}",
                                 label, f"{title} ({which})")
        out[key] = {"comparison": compared, "files": files}
    out["figure3"]["paper"] = paper.figure3()
    out["figure5"]["paper"] = paper.ABLATION.to_dict()
    # The paper's test asks whether the first experiment (topology + weights) is the faster.
    labels = list(campaign.fed("figure5").values())
    out["figure5"]["one_sided"] = {
        shape: {which: evolution.one_sided(c[which], *labels) if len(labels) == 2 else None
                for which in ("logged", "validation")}
        for shape, c in out["figure5"]["comparison"].items()}
    out["figure11"]["paper"] = paper.VELOCITY_BY_OMEGA.to_dict()
    return out


def _reassembly_figures(campaign, loaded, folder: Path) -> dict:
    reassemblies = reassembly.reassembly_rows(campaign, loaded)
    rows = reassembly.reoptimization_rows(campaign, loaded)
    out = {"reassemblies": reassemblies, "reoptimizations": rows}
    for key, label, reported in (
        ("figure7", reassembly.figure7_label(campaign),
         {k: r.to_dict() for k, r in paper.RHO_HOMOGENEOUS.items()}),
        ("figure8", reassembly.figure8_label(campaign), paper.RHO_BY_OMEGA.to_dict()),
        ("rq3_reassembly", reassembly.discovered_label(campaign), None),
    ):
        found = reassembly.rho_curves(rows, loaded, label)
        out[key] = {"curves": found, "end": reassembly.end_comparison(found),
                    "files": _save(figures.rho_figure, found, folder, key, TITLES[key]),
                    "paper": reported}
    eta = reassembly.eta_by_omega(campaign, reassemblies)
    files = {}
    for which in ("eta_num", "eta_weight"):
        panels = {shape: {g: d["values"] for g, d in e[which]["groups"].items()}
                  for shape, e in eta.items()}
        files[which] = _save(figures.boxes_figure, panels, folder, f"figure9-{which}",
                             which.replace("_", " "), f"Figure 9: {which} by omega")
    out["figure9"] = {"eta": eta, "files": files, "paper": paper.ETA_MODULAR.to_dict()}
    return out


def _discovery(campaign, loaded, folder: Path) -> dict:
    rows = discovery_rows(campaign, loaded)
    files = _save(figures.discovery_figure, rows, folder, "figure12-discovery") \
        if any(r["done"] for r in rows) else []
    return {"robots": rows, "summary": discovery_summary(rows), "files": files}


def _validation(rows: list[dict], n_terrains: int, folder: Path) -> dict:
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
    files = _save(figures.validation_figure, rows, folder, "validation") if rows else []
    return {"terrains": n_terrains, "robots": rows, "summary": table, "files": files}


def _save(draw, data, folder: Path, stem: str, *args) -> list[str]:
    """Draw and save a figure; nothing (no file) when there is nothing to draw."""
    if not data:
        return []
    return figures.save(draw(data, *args), folder, stem)


__all__ = ["build_report"]
