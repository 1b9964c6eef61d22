"""Plots of run directories: the paper's Figures 3/10 (curves) and 5/11 (boxplots).

Curves: the best individual's v_x and size |G| over the generations, as the median across the
runs of each group with a band of +/- one standard deviation; where the logs have a
``validation_velocity`` (the best re-run on the fixed validation terrains), it is drawn dashed
over the training v_x, which is the luckiest terrain draw. Boxplots: the best v_x at the last
generation, one point per run, with the two-sided Mann-Whitney p-value of every pair of groups
on a bar above them, marked "(n < 3)" where a group is too small for it to mean anything
(:data:`~somite.analysis.stats.MIN_GROUP_SIZE`). Groups are runs sharing the value of a
``config.json`` key (``shape``, ``omega``, ``weights_only``, ... or several, comma-separated).
The numbers come from :mod:`somite.analysis.stats`, which ``somite plot`` also writes as JSON
beside the figure.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .._io import check_output_file
from .._visible import for_figure
from ..analysis.stats import (
    MIN_GROUP_SIZE,
    PairTest,
    RunLog,
    final_values,
    group_runs,
    load_run,
    pairwise_mann_whitney,
    run_statistics,
    to_json,
)
from ..errors import bad
from .output import atomic_output, check_output

PLOT_FORMATS = (".png", ".svg", ".pdf")
PLOT_KINDS = ("curves", "box", "both")
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#7f7f7f", "#bcbd22", "#17becf")


def stats_path(out_path: str | os.PathLike) -> Path:
    """Where the statistics of a figure go: ``fig.png`` -> ``fig.stats.json``."""
    out_path = Path(out_path)
    return out_path.with_name(out_path.stem + ".stats.json")


def plot_runs(
    run_dirs: Sequence[str | os.PathLike],
    out_path: str | os.PathLike,
    group_by: str = "shape",
    kind: str = "both",
) -> Path:
    """Plot run directories into ``out_path`` and write their statistics beside it.

    Parameters
    ----------
    run_dirs : sequence of paths
        Run directories, each with ``config.json`` and ``log.csv``.
    out_path : path
        ``.png``, ``.svg`` or ``.pdf``; the statistics go to :func:`stats_path`.
    group_by : str
        One or more ``config.json`` keys, comma-separated.
    kind : str
        ``curves``, ``box`` or ``both`` (``both`` shows the curves alone when no group has
        two runs or more).

    Returns
    -------
    Path
        ``out_path``.
    """
    out_path = check_output(out_path, PLOT_FORMATS)
    check_output_file(stats_path(out_path))  # read-only or too long a name: refused now
    if kind not in PLOT_KINDS:
        raise bad("kind", kind, f"use one of {list(PLOT_KINDS)}")
    if not run_dirs:
        raise bad("runs", "", "give at least one run directory")
    groups = group_runs([load_run(path) for path in run_dirs], group_by)
    if kind == "both" and all(len(runs) < 2 for runs in groups.values()):
        kind = "curves"  # a box of one run says nothing: show the curves alone
    figure = _figure(groups, kind, group_by)
    data = {"group_by": group_by, **run_statistics(groups)}
    # Both written before either is renamed: a failed write (a full disk) leaves the old
    # figure and the old statistics, never a new one beside an old other.
    with atomic_output(out_path) as tmp_figure:
        figure.savefig(tmp_figure, dpi=110, format=out_path.suffix.lower().lstrip("."))
        with atomic_output(stats_path(out_path)) as tmp_stats:
            tmp_stats.write_text(to_json(data), encoding="utf-8")
    return out_path


def _runs(count: int) -> str:
    return f"{count} run" if count == 1 else f"{count} runs"


def _figure(groups: dict[str, list[RunLog]], kind: str, group_by: str):
    # No pyplot: no global figure registry and no GUI backend to pick.
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width = {"curves": 5.5, "box": 1.6 + 1.1 * len(groups), "both": 6.0 + 1.1 * len(groups)}
    figure = Figure(figsize=(max(4.5, width[kind]), 5.2), layout="constrained")
    FigureCanvasAgg(figure)
    if kind == "curves":
        top, bottom = figure.subplots(2, 1, sharex=True)
        box = None
    elif kind == "box":
        top = bottom = None
        box = figure.subplots(1, 1)
    else:
        grid = figure.add_gridspec(2, 2, width_ratios=(5.5, max(2.0, 1.1 * len(groups))))
        top = figure.add_subplot(grid[0, 0])
        bottom = figure.add_subplot(grid[1, 0], sharex=top)
        box = figure.add_subplot(grid[:, 1])
    if top is not None:
        plot_curves(top, groups, "best_velocity", "best $v_x$ [m/s]")
        plot_validation(top, groups)
        plot_curves(bottom, groups, "best_size", "|G| of the best")
        bottom.set_xlabel("generation")
        top.legend(fontsize=7, frameon=False)
    if box is not None:
        plot_boxes(box, groups)
    total = sum(len(r) for r in groups.values())
    figure.suptitle(f"{_runs(total)} grouped by {group_by}",
                    fontsize=9)
    return figure


def curve(runs: Sequence[RunLog], column: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Generations, median and standard deviation of ``column`` across ``runs``.

    Runs of different lengths are aligned on the generation number; each generation's numbers
    use the runs that reached it.
    """
    generations = np.unique(np.concatenate([run.log["generation"] for run in runs]))
    table = np.full((len(runs), len(generations)), np.nan)
    for i, run in enumerate(runs):
        table[i, np.searchsorted(generations, run.log["generation"])] = run.log[column]
    with warnings.catch_warnings():
        # A generation where every run logged NaN gives NaN; numpy would also warn about it.
        warnings.simplefilter("ignore", RuntimeWarning)
        return generations, np.nanmedian(table, axis=0), np.nanstd(table, axis=0)


def plot_curves(axes, groups: dict[str, list[RunLog]], column: str, label: str) -> None:
    """Median +/- standard deviation of ``column`` over generations, one colour per group."""
    for k, (name, runs) in enumerate(groups.items()):
        colour = COLOURS[k % len(COLOURS)]
        x, median, std = curve(runs, column)
        axes.fill_between(x, median - std, median + std, color=colour, alpha=0.2, lw=0)
        axes.plot(x, median, color=colour, lw=1.5,
                  label=f"{for_figure(name)} ({_runs(len(runs))})")
    axes.set_ylabel(label)
    axes.grid(alpha=0.3)


def plot_validation(axes, groups: dict[str, list[RunLog]]) -> None:
    """The best's mean v_x on the validation terrains (the logs' ``validation_velocity``),
    median across each group's runs, dashed with markers, where the logs measured it."""
    for k, (name, runs) in enumerate(groups.items()):
        x, median, _ = curve(runs, "validation_velocity")
        shown = np.isfinite(median)
        if shown.any():
            axes.plot(x[shown], median[shown], color=COLOURS[k % len(COLOURS)], lw=1.0,
                      ls="--", marker="o", ms=3,
                      label=f"{for_figure(name)}, on validation terrains")


def plot_boxes(
    axes, groups: dict[str, list[RunLog]], column: str = "best_velocity"
) -> list[PairTest]:
    """Boxplots of the last generation's ``column`` per group, every run as a dot, and the
    pairwise Mann-Whitney p-values on bars above; returns the tests drawn."""
    samples = {name: final_values(runs, column) for name, runs in groups.items()}
    return plot_samples(axes, samples, "best $v_x$ at the last generation [m/s]")


def plot_samples(axes, samples: dict[str, np.ndarray], ylabel: str,
                 one_sided: tuple[str, str] | None = None) -> list[PairTest]:
    """Boxplots of one sample per group, every value as a dot, and the pairwise two-sided
    Mann-Whitney p-values on bars above; returns the tests drawn (two-sided). ``one_sided``
    (``a``, ``b``): the bar of that pair gives the one-sided p of H1 'a is greater than b'
    first (the paper's test of Figure 5), the two-sided p after it, each named."""
    samples = {name: np.asarray(values, dtype=np.float64) for name, values in samples.items()}
    samples = {name: values[np.isfinite(values)] for name, values in samples.items()}
    positions = np.arange(1, len(samples) + 1)
    data = [values if len(values) else [np.nan] for values in samples.values()]
    parts = axes.boxplot(data, positions=positions, widths=0.55,
                         tick_labels=[for_figure(n) for n in samples],
                         showfliers=False, patch_artist=True)
    for k, (patch, values) in enumerate(zip(parts["boxes"], samples.values())):
        colour = COLOURS[k % len(COLOURS)]
        patch.set(facecolor=colour, alpha=0.35, edgecolor=colour)
        jitter = np.random.default_rng(k).uniform(-0.12, 0.12, len(values))
        axes.scatter(positions[k] + jitter, values, s=12, color=colour, zorder=3)
    for median in parts["medians"]:
        median.set(color="black", lw=1.5)
    tests = pairwise_mann_whitney(samples)
    _p_value_bars(axes, tests, list(samples), samples, one_sided)
    axes.set_ylabel(ylabel)
    axes.ticklabel_format(axis="y", useOffset=False)
    axes.tick_params(axis="x", labelrotation=20 if len(samples) > 2 else 0, labelsize=8)
    axes.grid(axis="y", alpha=0.3)
    return tests


def _p_value_bars(axes, tests: list[PairTest], names: list[str], samples: dict,
                  one_sided: tuple[str, str] | None = None) -> None:
    values = np.concatenate([v for v in samples.values()] + [np.zeros(0)])
    if len(values) == 0:
        return
    low, high = float(np.min(values)), float(np.max(values))
    step = 0.09 * max(high - low, 1e-6)
    # Short bars (neighbours) low, long ones above them, so no bar crosses a label.
    order = sorted(tests, key=lambda t: (names.index(t.b) - names.index(t.a), names.index(t.a)))
    for level, test in enumerate(order, start=1):
        a, b = names.index(test.a) + 1, names.index(test.b) + 1
        y = high + level * step
        axes.plot([a, a, b, b], [y - 0.3 * step, y, y, y - 0.3 * step], color="black", lw=0.8)
        text = _p_text(test.p)
        if one_sided is not None and {test.a, test.b} == set(one_sided):
            a_name, b_name = one_sided
            greater = mann_whitney_greater(samples[a_name], samples[b_name])
            text = f"one-sided {_p_text(greater)}, two-sided {_p_text(test.p)}"
        text += f" (n < {MIN_GROUP_SIZE})" if test.caveat else ""
        axes.text(0.5 * (a + b), y, text, ha="center", va="bottom", fontsize=7)
    axes.set_ylim(low - step, high + (len(order) + 1.2) * step)


def mann_whitney_greater(a, b) -> float:
    """The one-sided Mann-Whitney p of H1 'sample ``a`` is greater than sample ``b``' (NaN
    when a sample is empty)."""
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    from scipy.stats import mannwhitneyu  # slow to import: only where a figure asks for it

    return float(mannwhitneyu(a, b, alternative="greater").pvalue)


def _p_text(p: float) -> str:
    if not np.isfinite(p):
        return "p = n/a"
    return "p < 0.001" if p < 0.001 else f"p = {p:.3g}"


__all__ = ["COLOURS", "PLOT_FORMATS", "curve", "plot_boxes", "plot_curves", "plot_runs",
           "plot_samples", "plot_validation", "stats_path"]
