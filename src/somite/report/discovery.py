"""Module discovery in numbers (paper section 5.3, Figure 12): the partition found for every
evolved best, and how often the most compact module joins the front and the rear.

The paper's one observation is qualitative: the bipeds' most compact module "tends to span
horizontally across the body, connecting the front with the rear". Here a module *spans* when
it holds a voxel of the body's first column and one of its last.
"""

from __future__ import annotations

import numpy as np

from ..analysis.stats import describe
from ..viz import report_figures as figures
from . import paper
from .campaign import CampaignFolder, task_row
from .evolution import shape_order
from .load import Loaded, shape_name
from .reassembly import render_discovered
from .section import Inputs, Section
from .text import claim, images, median_sd, number, table


def discovery_rows(campaign: CampaignFolder, loaded: Loaded) -> list[dict]:
    """One row per discover task: the partition, the most compact module and its score."""
    rows = []
    for task in campaign.of_kind("discover"):
        found = loaded.discovery.get(task.id)
        row = {**task_row(task, found is not None), "genome": task.options.get("genome")}
        if found is not None:
            partition = found["partition"]
            voxels = [tuple(v) for v in found["best"]["voxels"]]
            columns = [x for x, _ in partition.shape.voxels]
            row.update({
                "shape": shape_name(partition.shape.grid_string()),
                "grid": partition.grid_string(),
                "shape_grid": partition.shape.grid_string(),
                "modules": len(partition.modules),
                "best_voxels": [list(v) for v in voxels],
                "best_size": len(voxels),
                "compactness": found["best"].get("compactness"),
                # Older partition files lack it: None, shown as nothing.
                "tied_with_best": found.get("tied_with_best"),
                "spans_front_to_rear": bool({min(columns), max(columns)}
                                            <= {x for x, _ in voxels}),
                "b_min": found.get("b_min"), "b_max": found.get("b_max"),
            })
        rows.append(row)
    return rows


def discovery_summary(rows: list[dict]) -> dict:
    """Per shape: robots partitioned, modules per robot, the most compact module's size and
    compactness, and the share of those modules that span front to rear."""
    by_shape: dict[str, list[dict]] = {}
    for row in rows:
        if row["done"]:
            by_shape.setdefault(row["shape"], []).append(row)
    out = {}
    for shape in shape_order(by_shape):
        members = by_shape[shape]
        compactness = [np.nan if r["compactness"] is None else r["compactness"] for r in members]
        out[shape] = {
            "robots": len(members),
            "modules": describe([r["modules"] for r in members]),
            "best_size": describe([r["best_size"] for r in members]),
            "compactness": describe(compactness),
            "spans_front_to_rear": float(np.mean([r["spans_front_to_rear"] for r in members])),
        }
    out["paper"] = paper.DISCOVERY.to_dict()
    return out


def build(inputs: Inputs) -> dict:
    """The discover experiments' entry of report.json: ``discovery``."""
    rows = discovery_rows(inputs.campaign, inputs.loaded)
    files = inputs.save(figures.discovery_figure, rows, "figure12-discovery") \
        if any(r["done"] for r in rows) else []
    return {"discovery": {"robots": rows, "summary": discovery_summary(rows), "files": files}}


def render(report: dict) -> list[str]:
    """index.md's lines of the discovery (Figure 12), then of the reassembly along the
    discovered modules (made by a reassemble experiment, read after the discovery)."""
    data = report["discovery"]
    lines = ["## Figure 12: automatic module discovery", "",
             "Each evolved best partitioned around its most compact module (eq. 5; red in the "
             "figure). A module *spans* when it holds voxels of the body's first and last "
             f"column. {claim(data['summary']['paper'])}", ""]
    rows = [[shape, s["robots"], number(s["modules"]["median"], 1),
             number(s["best_size"]["median"], 1), median_sd(s["compactness"]),
             f"{100 * s['spans_front_to_rear']:.0f} %"]
            for shape, s in data["summary"].items() if shape != "paper"]
    lines += table(["shape", "robots", "median modules", "median size of the most compact",
                    "its compactness", "spans front to rear"], rows)
    rows = [[r["task"], r.get("grid", "missing"), number(r.get("compactness")) + _tied(r),
             r.get("spans_front_to_rear", "")] for r in data["robots"]]
    lines += table(["robot", "partition (rows from the top)", "compactness", "spans"], rows)
    return lines + images(data["files"], "Figure 12") + render_discovered(report)


def _tied(row: dict) -> str:
    """Beside a discovered module's compactness: how many other candidates share it."""
    tied = row.get("tied_with_best")
    if not tied:
        return ""
    others = "1 other candidate" if tied == 1 else f"{tied} other candidates"
    return f" (tied with {others}; the first ranked is taken)"


SECTION = Section(build, render)
"""The discover experiments' part of the report."""

__all__ = ["SECTION", "build", "discovery_rows", "discovery_summary", "render"]
