"""The figures of ``somite report`` (:mod:`somite.report`), each written as PNG and SVG
(atomically), one panel per shape.

The curves and boxes are drawn by :mod:`somite.viz.plots` (the same code as ``somite plot``),
so a figure of the report and one of ``somite plot`` on the same runs agree.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from .._visible import for_figure
from .output import atomic_output
from .plots import COLOURS, plot_curves, plot_samples, plot_validation

FORMATS = ("png", "svg")
MODULE_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf")
"""The most compact module (``A``) red, as in the paper's Figure 12; the others after it."""


def _figure(columns: int, rows: int = 1, width: float = 4.6, height: float = 3.4):
    # No pyplot: no global figure registry and no GUI backend to pick.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(max(1, columns) * width, rows * height), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(rows, max(1, columns), squeeze=False)
    return figure, axes


def _title(figure, title: str) -> None:
    """The figure's title, wrapped to its width: a one-panel figure cut a long one at both
    edges (about 12 characters an inch at this size)."""
    figure.suptitle(textwrap.fill(title, max(20, int(figure.get_figwidth() * 12))), fontsize=10)


def save(figure, folder: Path, stem: str) -> list[str]:
    """Write ``stem.png`` and ``stem.svg`` into ``folder``; returns their names. The same
    figure gives the same bytes: the SVG carries no date and its ids are salted with a constant,
    so a report regenerated on the same numbers changes no figure in a repository."""
    import matplotlib

    names = []
    for fmt in FORMATS:
        path = folder / f"{stem}.{fmt}"
        with atomic_output(path) as tmp, matplotlib.rc_context({"svg.hashsalt": "somite"}):
            figure.savefig(tmp, dpi=110, format=fmt,
                           metadata={"Date": None} if fmt == "svg" else None)
        names.append(path.name)
    return names


def curves_figure(found: dict, title: str):
    """Figures 3 and 10: per shape (columns), the best's v_x (top, dashed: on the validation
    terrains) and |G| (bottom), median +/- sd across runs, one colour per group."""
    figure, axes = _figure(len(found), 2, height=3.0)
    for column, (shape, groups) in enumerate(found.items()):
        top, bottom = axes[0, column], axes[1, column]
        listed = {label: list(runs.values()) for label, runs in groups.items()}
        plot_curves(top, listed, "best_velocity", "best $v_x$ [m/s]")
        plot_validation(top, listed)
        plot_curves(bottom, listed, "best_size", "|G| of the best")
        top.set_title(shape, fontsize=10)
        bottom.set_xlabel("generation")
        if column == 0:
            top.legend(fontsize=6, frameon=False)
    _title(figure, title)
    return figure


def cut_curves_figure(found: dict, title: str):
    """The cuts during evolution: per shape (columns), eta_num (top) and eta_weight (bottom)
    of the best, median +/- sd across runs, one colour per group (``found``: shape -> group ->
    runs whose logs hold ``eta_num`` and ``eta_weight``)."""
    figure, axes = _figure(len(found), 2, height=3.0)
    for column, (shape, groups) in enumerate(found.items()):
        top, bottom = axes[0, column], axes[1, column]
        plot_curves(top, groups, "eta_num", r"$\eta_{num}$ of the best")
        plot_curves(bottom, groups, "eta_weight", r"$\eta_{weight}$ of the best")
        top.set_title(shape, fontsize=10)
        bottom.set_xlabel("generation")
        if column == 0:
            top.legend(fontsize=6, frameon=False)
    _title(figure, title)
    return figure


def boxes_figure(panels: dict[str, dict[str, list[float]]], ylabel: str, title: str,
                 one_sided: tuple[str, str] | None = None):
    """Figures 5, 9 and 11: per shape, one box per group with the pairwise p-values
    (two-sided Mann-Whitney U). ``one_sided`` (``a``, ``b``): that pair's bar also gives the
    one-sided p of H1 'a is greater than b' (Figure 5: the paper's test), and a line under
    the panels says which p is which."""
    figure, axes = _figure(len(panels), width=1.6 + 1.2 * max(
        (len(p) for p in panels.values()), default=1))
    for column, (shape, samples) in enumerate(panels.items()):
        plot_samples(axes[0, column], samples, ylabel, one_sided=one_sided)
        axes[0, column].set_title(shape, fontsize=10)
    _title(figure, title)
    if one_sided is not None:
        figure.supxlabel(f"Mann-Whitney U: one-sided p of H1 '{one_sided[0]} > {one_sided[1]}' "
                         "(the paper's test), then the two-sided p", fontsize=7)
    return figure


def rho_figure(found: dict, title: str):
    """Figures 7 and 8: per shape, the median rho per generation of each group (band: +/- sd
    across the re-optimisations); rho = 1 recovers the donors' mean v_x."""
    figure, axes = _figure(len(found))
    for column, (shape, groups) in enumerate(found.items()):
        axes_ = axes[0, column]
        for k, (label, data) in enumerate(groups.items()):
            colour = COLOURS[k % len(COLOURS)]
            x = np.asarray(data["generation"])
            median, sd = np.asarray(data["median"]), np.asarray(data["sd"])
            axes_.fill_between(x, median - sd, median + sd, color=colour, alpha=0.15, lw=0)
            axes_.plot(x, median, color=colour, lw=1.5,
                       label=f"{for_figure(label)} ({len(data['tasks'])})")
        axes_.axhline(1.0, color="black", lw=0.8, ls=":")
        axes_.set_title(shape, fontsize=10)
        axes_.set_xlabel("generation of the re-optimisation")
        axes_.set_ylabel(r"median $\rho$")
        axes_.grid(alpha=0.3)
        axes_.legend(fontsize=7, frameon=False)
    _title(figure, title)
    return figure


def edge_lengths_figure(found: dict, title: str):
    """The final bests' edge lengths: per shape, for each length [voxels] between voxels the
    share of each group's edges (pooled over its runs) that have it, the groups' bars side by
    side; the share inside a voxel (length 0) is in the legend."""
    figure, axes = _figure(len(found), width=5.2, height=4.0)
    for column, (shape, groups) in enumerate(found.items()):
        axes_ = axes[0, column]
        # Edges inside a voxel are most of a young controller's: as a bar they would flatten
        # the lengths the two options act on.
        lengths = sorted({d for e in groups.values() for d in e["lengths"] if d > 0})
        # Lengths as categories: 2.828 and 3 would overlap on a scale of voxels.
        width = 0.8 / len(groups)
        for k, (label, e) in enumerate(groups.items()):
            share = dict(zip(e["lengths"], e["shares"]))
            x = np.arange(len(lengths)) + (k - (len(groups) - 1) / 2) * width
            axes_.bar(x, [share.get(d, 0.0) for d in lengths], width,
                      color=COLOURS[k % len(COLOURS)],
                      label=f"{for_figure(label)} ({len(e['runs'])} runs, {e['edges']} edges, "
                            f"{100 * share.get(0.0, 0.0):.0f} % inside a voxel)")
        axes_.set_xticks(np.arange(len(lengths)),
                         [f"{d:.3f}".rstrip("0").rstrip(".") for d in lengths], fontsize=7)
        axes_.set_title(shape, fontsize=10)
        axes_.set_xlabel("length of an edge between voxels [voxels]")
        axes_.set_ylabel("share of the group's edges")
        axes_.grid(alpha=0.3, axis="y")
        # Below the panel: above it the legend would hide the bars.
        axes_.legend(fontsize=7, frameon=False, loc="upper center",
                     bbox_to_anchor=(0.5, -0.18))
    _title(figure, title)
    return figure


def validation_figure(rows: list[dict]):
    """Every final best: its logged v_x (x) against its mean v_x on the validation terrains
    (y, filled), and on the fresh terrains where the rows have them (hollow), one colour per
    experiment; the diagonal is 'as good as logged'."""
    figure, axes = _figure(1, width=5.6, height=4.4)
    axes_ = axes[0, 0]
    experiments = list(dict.fromkeys(r["experiment"] for r in rows))
    fresh = bool(rows) and all("fresh" in r for r in rows)
    for k, experiment in enumerate(experiments):
        members = [r for r in rows if r["experiment"] == experiment]
        colour = COLOURS[k % len(COLOURS)]
        axes_.scatter([r["logged"] for r in members], [r["validation"] for r in members], s=14,
                      color=colour, label=experiment)
        if fresh:
            axes_.scatter([r["logged"] for r in members], [r["fresh"] for r in members], s=18,
                          facecolors="none", edgecolors=colour, linewidths=0.9)
    measured = ("logged", "validation", "fresh") if fresh else ("logged", "validation")
    values = [r[k] for r in rows for k in measured if np.isfinite(r[k])]
    if values:
        low, high = min(values), max(values)
        axes_.plot([low, high], [low, high], color="black", lw=0.8, ls=":")
    axes_.set_xlabel("logged best $v_x$ at the last generation [m/s]")
    axes_.set_ylabel("mean $v_x$ on the validation terrains (filled)\nand on fresh ones "
                     "(hollow) [m/s]" if fresh else "mean $v_x$ on the validation terrains [m/s]")
    axes_.grid(alpha=0.3)
    axes_.legend(fontsize=7, frameon=False)
    return figure


def discovery_figure(rows: list[dict], per_row: int = 5):
    """Figure 12: every partitioned robot, one colour per module, the most compact red."""
    from matplotlib.patches import Rectangle

    from ..sim.partition import Partition

    done = [r for r in rows if r["done"]]
    columns = min(per_row, max(1, len(done)))
    lines = max(1, -(-len(done) // columns))
    figure, axes = _figure(columns, lines, width=1.9, height=1.6)
    for axes_ in axes.flat:
        axes_.set_axis_off()
    for axes_, row in zip(axes.flat, done):
        partition = Partition.from_grid(row["grid"], row["shape_grid"])
        others = [m for m in partition.modules if m != "A"]
        for (x, y), label in zip(partition.shape.voxels, partition.labels):
            k = 0 if label == "A" else 1 + others.index(label) % (len(MODULE_COLOURS) - 1)
            axes_.add_patch(Rectangle((x, y), 1, 1, facecolor=MODULE_COLOURS[k],
                                      edgecolor="white", alpha=0.85))
        axes_.set_xlim(0, partition.shape.width)
        axes_.set_ylim(0, partition.shape.height)
        axes_.set_aspect("equal")
        compactness = row["compactness"]
        shown = "n/a" if compactness is None else f"{compactness:.2f}"
        axes_.set_title(f"{row['task'].split('/', 1)[-1]}\nc = {shown}", fontsize=7)
    return figure


__all__ = ["boxes_figure", "curves_figure", "discovery_figure", "edge_lengths_figure",
           "rho_figure", "save", "validation_figure"]
