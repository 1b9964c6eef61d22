"""``somite demo``: a short evolution, then a video of its best robot and a plot of the run."""

from __future__ import annotations

import argparse

from .._io import check_output_folder
from ..experiments.config import resolve
from ..experiments.runner import RunDirectory, evolve
from .common import add_options
from .evolve import progress_bar, summarise

HELP = "Evolve a worm on flat ground for 60 generations, render its best gait, plot the run."

DEMO = {"shape": "worm", "population": 48, "generations": 60, "duration": 20.0, "seed": 0,
        "terrain": "flat", "reevaluate_parents": False}
"""Small enough for a laptop in under a minute; big enough to show clear progress. On flat
ground, because at so small a budget the best of a generation on random hilly terrains is
mostly the robot that drew the luckiest terrain, and would barely walk on another. Parents
are not evaluated again: on one fixed terrain that would only double the time."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="demo", help="output folder")
    parser.add_argument("--generations", type=int, default=DEMO["generations"])
    add_options(parser, "quiet")


def run(args: argparse.Namespace) -> int:
    from ..viz.plots import plot_runs
    from ..viz.video import render_episode

    out = check_output_folder(args.out)
    run_dir = out / "run"
    config = resolve({**DEMO, "generations": args.generations})
    with progress_bar(config.generations, args.quiet) as report:
        ea = evolve(config, run_dir, force=True, progress=report)
    summarise(ea, RunDirectory(run_dir), args.quiet)
    video = render_episode(ea.best, out / "best.mp4", terrain_name=config.terrain,
                           duration=config.duration)
    plot = plot_runs([run_dir], out / "run.png", group_by="shape")
    print(f"video of the best robot: {video}")
    print(f"plot of the run:         {plot}")
    return 0
