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
from ..viz.plots import curve
from . import paper
from .campaign import CampaignFolder, Task, task_row
from .evolution import compare, shape_order
from .load import Loaded, shape_name


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


__all__ = ["discovered_label", "end_comparison", "eta_by_omega", "figure7_label",
           "figure8_label", "reassembly_rows", "reoptimization_rows", "rho_curves"]
