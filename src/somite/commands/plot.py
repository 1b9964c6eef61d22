"""``somite plot``: curves and boxplots of run directories (paper Figures 3, 5, 10, 11)."""

from __future__ import annotations

import argparse
import json

from ..analysis.stats import smallest_p
from ..viz.output import check_output
from ..viz.plots import PLOT_FORMATS, PLOT_KINDS, plot_runs, stats_path
from .common import warn

HELP = "Plot best v_x and |G| over generations and final-v_x boxplots with Mann-Whitney p."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", nargs="+", help="run directories (config.json and log.csv)")
    parser.add_argument("--out", default="runs.png", help="fig.png, fig.svg or fig.pdf; the "
                        "statistics go beside it as fig.stats.json")
    parser.add_argument("--group-by", default="shape",
                        help="config.json key(s), comma-separated: shape, omega, weights_only, ...")
    parser.add_argument("--kind", default="both", choices=PLOT_KINDS,
                        help="learning curves, box plots of the final bests, or both")


def run(args: argparse.Namespace) -> int:
    out = check_output(args.out, PLOT_FORMATS)
    plot_runs(args.runs, out, args.group_by, args.kind)
    stats = json.loads(stats_path(out).read_text(encoding="utf-8"))
    print(f"wrote {out} and {stats_path(out)}")
    for label, group in stats["groups"].items():
        median = group["median"]
        shown = "n/a" if median is None else f"{median:.3f} m/s"
        print(f"  {label}: {group['n']} runs, median final best v_x {shown}")
    for test in stats["tests"]:
        p = "n/a" if test["p"] is None else f"{test['p']:.4g}"
        print(f"  {test['a']} vs {test['b']}: Mann-Whitney U = {test['u']}, p = {p}")
        if test["caveat"]:
            warn(args.prog, small_groups(test))
    total = sum(len(group["runs"]) for group in stats["groups"].values())
    left_out = stats["left_out"]
    if left_out:
        warn(args.prog, left_out_runs(left_out, total, stats_path(out)))
    whole = stats["whole_episode_runs"]
    if whole:
        warn(args.prog, f"{len(whole)} of {total} runs had a duration no longer than their "
             f"transient, so v_x is over the whole episode, start-up included (first: {whole[0]})")
    return 0


SHOWN_RUNS = 5
"""The most left-out runs a warning names (stats.json lists them all)."""


def left_out_runs(runs: list[str], total: int, stats) -> str:
    """The warning naming the runs whose final best is NaN or infinite (in no box, no test)."""
    shown = ", ".join(runs[:SHOWN_RUNS])
    more = f" and {len(runs) - SHOWN_RUNS} more (listed in {stats})" \
        if len(runs) > SHOWN_RUNS else ""
    return (f"{len(runs)} of {total} runs left out: their final best v_x is NaN or infinite, "
            f"so they are in no box, median or test: {shown}{more}")


def small_groups(test: dict) -> str:
    """The warning beside the p-value of groups too small for it (a test of stats.json)."""
    p = "n/a" if test["p"] is None else f"{test['p']:.4g}"
    return (f"{test['a']} vs {test['b']}: p = {p} from {test['n_a']} and "
            f"{test['n_b']} runs ({test['caveat']}; no data could give a p below "
            f"{smallest_p(test['n_a'], test['n_b']):.3g} with so few)")
