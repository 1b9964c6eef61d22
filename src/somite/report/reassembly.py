"""Reassembly and re-optimisation in numbers: rho per generation (Figures 7 and 8, and along
the discovered modules), and the cut ratios eta by omega (Figure 9).

A re-optimisation is tied to its reassembly (its ``start`` option, else the reassemble task it
needs), and a reassembly to its donors (its ``donors`` option, else the evolve tasks it needs);
omega is the donors' (their ``config.json``, else their task options). Which experiments feed
Figures 7, 8 and 9 and the discovered modules' curve is the campaign's declaration
(``campaign.fed("figure7")``). rho is read from
``transfer.csv``, which ``somite reoptimize`` measured on the validation terrains; eta is the
reassembly's pooled cut ratio (the authors' count over both donors; docs/decisions.md, "Cut
ratios").
"""

from __future__ import annotations

import numpy as np

from ..analysis.stats import RunLog
from ..viz import report_figures as figures
from ..viz.plots import curve
from . import paper
from .campaign import CampaignFolder, Task, task_row
from .evolution import compare, shape_order
from .load import Loaded, shape_name
from .section import Inputs, Section
from .text import claim, images, images_of, number, pair_rows, table, tests_table

TITLES = {
    "figure7": "Figure 7: rho during re-optimisation, homogeneous and heterogeneous reassembly",
    "figure8": "Figure 8: rho during re-optimisation by omega (homogeneous reassembly)",
    "figure9": "Figure 9: edges cut by disassembly (eta) by omega",
    "rq3_reassembly": "Beyond the paper: reassembly along the discovered modules",
}
"""The heading of each of this section's entries in index.md, by its key in report.json (the
title drawn on its figure too)."""


def _linked(campaign: CampaignFolder, task: Task, option: str, kind: str) -> list[Task]:
    value = task.options.get(option)
    ids = [value] if isinstance(value, str) else value if isinstance(value, list) else None
    if ids is None:
        ids = list(task.needs)
    found = [campaign.task(i) for i in ids if isinstance(i, str)]
    return [t for t in found if t is not None and t.kind == kind]


def omega_of(task: Task, loaded: Loaded) -> float | None:
    if task.id in loaded.runs:
        return float(loaded.runs[task.id].config.get("omega", 1.0))
    value = task.options.get("omega")
    return float(value) if isinstance(value, (int, float)) else None


def donors_omega(campaign: CampaignFolder, reassembly: Task, loaded: Loaded) -> float | None:
    """The omega of the donors when they share one, else None."""
    values = {omega_of(t, loaded) for t in _linked(campaign, reassembly, "donors", "evolve")}
    return values.pop() if len(values) == 1 else None


def omega_label(omega: float | None) -> str:
    return "omega ?" if omega is None else f"omega {omega:g}"


def reassembly_rows(campaign: CampaignFolder, loaded: Loaded) -> list[dict]:
    """One row per reassemble task: receiver shape, kind, omega and the pooled eta."""
    rows = []
    for task in campaign.of_kind("reassemble"):
        report = loaded.reassembly.get(task.id)
        row = {**task_row(task, report is not None), "omega": donors_omega(campaign, task, loaded)}
        if report is not None:
            row.update({
                "shape": shape_name(report["receiver"]["shape"]), "kind": report.get("kind"),
                "eta_num": _float(report["pooled"].get("eta_num")),
                "eta_weight": _float(report["pooled"].get("eta_weight")),
                "modules": [{k: m.get(k) for k in ("module", "donor", "donor_module",
                                                   "eta_num", "eta_weight")}
                            for m in report.get("modules", [])],
            })
        rows.append(row)
    return rows


def reoptimization_rows(campaign: CampaignFolder, loaded: Loaded) -> list[dict]:
    """One row per reoptimize task: its reassembly's shape, kind and omega; rho at the start
    and at the end of the re-optimisation."""
    eta = {row["task"]: row for row in reassembly_rows(campaign, loaded)}
    rows = []
    for task in campaign.of_kind("reoptimize"):
        start = _linked(campaign, task, "start", "reassemble")
        origin = eta.get(start[0].id, {}) if start else {}
        row = {**task_row(task, task.id in loaded.transfer),
               "start": start[0].id if start else None, "omega": origin.get("omega"),
               "kind": origin.get("kind"), "shape": origin.get("shape")}
        if task.id in loaded.transfer:
            rho = [r["rho"] for r in loaded.transfer[task.id]]
            row.update({"shape": shape_name(loaded.runs[task.id].config["shape"]),
                        "generations": int(loaded.transfer[task.id][-1]["generation"]),
                        "rho_start": rho[0], "rho_end": rho[-1]})
        rows.append(row)
    return rows


def rho_curves(rows: list[dict], loaded: Loaded, label) -> dict:
    """Per shape and group (``label(row)``, None to leave a row out): the median rho across
    the re-optimisations per generation, with the sd and the per-task values at the end."""
    grouped: dict[str, dict[str, list[dict]]] = {}
    for row in rows:
        name = label(row)
        if row["done"] and name is not None:
            grouped.setdefault(row["shape"], {}).setdefault(name, []).append(row)
    out = {}
    for shape in shape_order(grouped):
        out[shape] = {}
        for name in sorted(grouped[shape]):
            members = grouped[shape][name]
            generation, median, sd = curve([_rho_run(loaded, r["task"]) for r in members],
                                           "rho")
            out[shape][name] = {
                "tasks": [r["task"] for r in members], "generation": generation.tolist(),
                "median": median.tolist(), "sd": sd.tolist(),
                "end": [r["rho_end"] for r in members],
            }
    return out


def _rho_run(loaded: Loaded, task_id: str) -> RunLog:
    # curve() aligns runs on the generation number; a rho curve is a run of one column.
    rows = loaded.transfer[task_id]
    log = {"generation": np.array([r["generation"] for r in rows]),
           "rho": np.array([r["rho"] for r in rows])}
    return RunLog(loaded.runs[task_id].path, loaded.runs[task_id].config, log)


def figure7_label(campaign: CampaignFolder):
    """A row's group in Figure 7: its experiment's label there (None: not in it)."""
    fed = campaign.fed("figure7")
    return lambda row: fed.get(row["experiment"])


def figure8_label(campaign: CampaignFolder):
    """A row's group in Figure 8: its donors' omega, for the homogeneous reassemblies."""
    fed = campaign.fed("figure8")

    def label(row: dict) -> str | None:
        if row["experiment"] in fed and row.get("kind") == "homogeneous":
            return omega_label(row["omega"])
        return None
    return label


def discovered_label(campaign: CampaignFolder):
    """A row's group in the discovered modules' curve."""
    fed = campaign.fed("discovered")
    return lambda row: fed.get(row["experiment"])


PAPER_PARTITION = "paper partition, same donors"
"""The group beside the discovered modules' curve: the homogeneous reassemblies (Figure 7) of
the same donor pairs, cut along the paper's partition instead."""


def discovered_or_paper_label(campaign: CampaignFolder, rows: list[dict]):
    """A row's group in the discovered modules' figure: the discovered modules' label, or
    :data:`PAPER_PARTITION` for a homogeneous reassembly of Figure 7 (whatever the campaign
    labels it there) whose donors are those of a reassembly along discovered modules, so that
    both partitions of one pair sit side by side."""
    discovered, homogeneous = discovered_label(campaign), figure7_label(campaign)

    def donors(row: dict) -> frozenset[str]:
        start = campaign.task(row["start"]) if row.get("start") else None
        if start is None:
            return frozenset()
        return frozenset(t.id for t in _linked(campaign, start, "donors", "evolve"))

    pairs = {donors(row) for row in rows if discovered(row) is not None} - {frozenset()}

    def label(row: dict) -> str | None:
        found = discovered(row)
        if found is not None:
            return found
        if (homogeneous(row) is not None and row.get("kind") == "homogeneous"
                and donors(row) in pairs):
            return PAPER_PARTITION
        return None
    return label


def end_comparison(found: dict) -> dict:
    """Per shape, the rho at the end of the re-optimisation compared between groups."""
    return {shape: compare({name: g["end"] for name, g in groups.items()},
                           {name: g["tasks"] for name, g in groups.items()})
            for shape, groups in found.items()}


def eta_by_omega(campaign: CampaignFolder, rows: list[dict]) -> dict:
    """Figure 9: per shape, eta_num and eta_weight of the homogeneous reassemblies of the
    experiments that feed Figure 8, by omega, compared pairwise; the paper's omega-1 medians
    beside."""
    grouped: dict[str, dict[str, list[dict]]] = {}
    fed = campaign.fed("figure8")
    for row in rows:
        if row["done"] and row["experiment"] in fed and row.get("kind") == "homogeneous":
            grouped.setdefault(row["shape"], {}).setdefault(omega_label(row["omega"]),
                                                            []).append(row)
    out = {}
    for shape in shape_order(grouped):
        labels = sorted(grouped[shape], key=_omega_order)
        ids = {k: [r["task"] for r in grouped[shape][k]] for k in labels}
        out[shape] = {
            key: compare({k: [r[key] for r in grouped[shape][k]] for k in labels}, ids)
            for key in ("eta_num", "eta_weight")
        }
        if shape in paper.ETA_NEUTRAL:
            out[shape]["paper_omega_1"] = {k: r.to_dict()
                                           for k, r in paper.ETA_NEUTRAL[shape].items()}
    return out


def _omega_order(label: str) -> float:
    try:
        return float(label.split()[-1])
    except ValueError:
        return float("inf")


def _float(value) -> float:
    return float("nan") if value is None else float(value)


def build(inputs: Inputs) -> dict:
    """The reassemble experiments' entries of report.json (with their re-optimisations'):
    the rows, the rho curves of Figures 7 and 8 and along the discovered modules, then the
    cut ratios of Figure 9."""
    campaign, loaded = inputs.campaign, inputs.loaded
    reassemblies = reassembly_rows(campaign, loaded)
    rows = reoptimization_rows(campaign, loaded)
    out = {"reassemblies": reassemblies, "reoptimizations": rows}
    for key, label, reported in (
        ("figure7", figure7_label(campaign),
         {**{k: r.to_dict() for k, r in paper.RHO_HOMOGENEOUS.items()},
          "heterogeneous": paper.RHO_HETEROGENEOUS.to_dict()}),
        ("figure8", figure8_label(campaign), paper.RHO_BY_OMEGA.to_dict()),
        ("rq3_reassembly", discovered_or_paper_label(campaign, rows), None),
    ):
        found = rho_curves(rows, loaded, label)
        out[key] = {"curves": found, "end": end_comparison(found),
                    "files": inputs.save(figures.rho_figure, found, key, TITLES[key]),
                    "paper": reported}
    eta = eta_by_omega(campaign, reassemblies)
    files = {}
    for which in ("eta_num", "eta_weight"):
        panels = {shape: {g: d["values"] for g, d in e[which]["groups"].items()}
                  for shape, e in eta.items()}
        files[which] = inputs.save(figures.boxes_figure, panels, f"figure9-{which}",
                                   which.replace("_", " "), f"Figure 9: {which} by omega")
    out["figure9"] = {"eta": eta, "files": files, "paper": paper.ETA_MODULAR.to_dict()}
    return out


def render(report: dict) -> list[str]:
    """index.md's lines of the reassemblies: rho (Figures 7 and 8), then eta (Figure 9). The
    reassembly along the discovered modules follows the discovery (:func:`render_discovered`)."""
    return _render_rho(report) + _render_eta(report)


def _rho_table(data: dict, reported=None) -> list[str]:
    rows, tests = [], []
    for shape, found in data["curves"].items():
        for group, g in found.items():
            start = [m[0] for m in [g["median"]] if m]
            said = ""
            if reported and group == "homogeneous" and shape in reported:
                said = reported[shape]["text"]
            elif reported and group == "heterogeneous" and group in reported:
                said = reported[group]["text"]
            rows.append([shape, group, len(g["tasks"]), number(start[0] if start else None),
                         number(g["median"][-1] if g["median"] else None), said])
        tests += pair_rows(data["end"][shape], shape)
    lines = table(["shape", "group", "re-optimisations", "median rho at the start",
                   "median rho at the end", "paper"], rows)
    if tests:
        lines += ["rho at the end of the re-optimisation, compared:", ""]
        lines += tests_table(tests, "shape")
    return lines


def _render_rho(report: dict) -> list[str]:
    lines = ["## Figures 7 and 8: transferability rho during re-optimisation", "",
             "rho = v_x of the re-optimised robot's best / mean v_x of its two donors, every v_x "
             "the mean over the validation terrains (transfer.csv); the line is the median over "
             "the reassembled robots, the band ± sd. rho = 1 recovers the donors' velocity.", ""]
    lines += [f"### {TITLES['figure7']}", ""]
    lines += _rho_table(report["figure7"], report["figure7"]["paper"])
    lines += images(report["figure7"]["files"], "Figure 7")
    lines += [f"### {TITLES['figure8']}", "",
              claim(report["figure8"]["paper"]), ""]
    lines += _rho_table(report["figure8"])
    lines += images(report["figure8"]["files"], "Figure 8")
    return lines


def _render_eta(report: dict) -> list[str]:
    data = report["figure9"]
    lines = [f"## {TITLES['figure9']}", "",
             "eta_num: share of the donors' edges that cross modules and are dropped; "
             "eta_weight: the same share of sum(|w| + |b|); pooled over both donors of each "
             "homogeneous reassembly (the authors' count).", "",
             claim(data["paper"]), ""]
    rows, tests = [], []
    for shape, e in data["eta"].items():
        reported = e.get("paper_omega_1", {})
        for group in e["eta_num"]["groups"]:
            num, weight = e["eta_num"]["groups"][group], e["eta_weight"]["groups"][group]
            said = ""
            if group == "omega 1" and reported:
                said = (f"{reported['eta_num']['value']} / {reported['eta_weight']['value']} "
                        f"({reported['eta_num']['where']})")
            rows.append([shape, group, num["n"], number(num["median"]),
                         number(weight["median"]), said])
        tests += pair_rows(e["eta_num"], f"{shape}, eta_num")
        tests += pair_rows(e["eta_weight"], f"{shape}, eta_weight")
    lines += table(["shape", "donors", "reassemblies", "median eta_num", "median eta_weight",
                    "paper (median eta_num / eta_weight)"], rows)
    lines += tests_table(tests)
    return lines + images_of((files, f"Figure 9, {which}")
                             for which, files in data["files"].items())


def render_discovered(report: dict) -> list[str]:
    """index.md's lines of the reassembly along the discovered modules."""
    data = report["rq3_reassembly"]
    lines = [f"## {TITLES['rq3_reassembly']}", ""]
    if any(PAPER_PARTITION in groups for groups in data["curves"].values()):
        lines += [f"Beside the discovered modules, \"{PAPER_PARTITION}\": the homogeneous "
                  "reassemblies of Figure 7 with the same donor pairs, cut along the paper's "
                  "partition; the test compares the two partitions' rho at the end.", ""]
    lines += _rho_table(data)
    return lines + images(data["files"], "rho along discovered modules")


SECTION = Section(build, render)
"""The reassemble experiments' part of the report (their re-optimisations' with it)."""

__all__ = ["PAPER_PARTITION", "SECTION", "TITLES", "build", "discovered_label",
           "discovered_or_paper_label", "end_comparison", "eta_by_omega", "figure7_label",
           "figure8_label", "reassembly_rows", "reoptimization_rows", "render",
           "render_discovered", "rho_curves"]
