"""``somite demo``: a short evolution, then a video of its best robot and a plot of the run."""

from __future__ import annotations

import argparse

from .._io import check_output_folder
from ..experiments.config import resolve
from ..experiments.runner import RunDirectory, evolve
from ..sim.terrain import parse_terrain
from ..tasks.validation import fresh_noise
from ..tasks.velocity import mean_velocity
from ._progress import rendering
from .common import add_options, whole_int
from .evolve import progress_bar, summarise

HELP = "Evolve a worm on flat ground for 60 generations, render its best gait, plot the run."

DEMO = {"shape": "worm", "population": 48, "generations": 60, "duration": 20.0, "seed": 0,
        "terrain": "flat", "reevaluate_parents": False}
"""Small enough for a laptop in under a minute; big enough to show clear progress. On flat
ground, because at so small a budget the best of a generation on random hilly terrains is
mostly the robot that drew the luckiest terrain, and would barely walk on another. Parents
are not evaluated again: on one fixed terrain the sensor noise is the only luck, and the demo
re-runs its best on fresh noise instead (:data:`RECHECKS`), which costs 5 episodes, not 60
generations' worth."""

RECHECKS = 5
"""Fresh sensor-noise draws the demo's best is re-run on, for the figure it reports."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="demo", help="output folder")
    parser.add_argument("--generations", type=whole_int("generations"),
                        default=DEMO["generations"],
                        help="generations after the initial population")
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
    sim = config.setup.sim
    fresh = fresh_noise(ea.best, parse_terrain(config.terrain), sim, RECHECKS, config.seed)
    if not args.quiet:
        print(recheck_line(ea.best_fitness, fresh, config.terrain))
        print(MEANING)
    with rendering("rendering the video", args.quiet) as progress:
        video = render_episode(ea.best, out / "best.mp4", terrain_name=config.terrain,
                               config=sim, progress=progress)
    plot = plot_runs([run_dir], out / "run.png", group_by="shape")
    print(f"video of the best robot: {video}")
    print(f"plot of the run:         {plot}")
    return 0


def recheck_line(training: float, fresh, terrain: str) -> str:
    """The best's v_x on fresh noise beside its training figure."""
    return (f"re-run on {terrain} with {len(fresh)} fresh noise draws: {mean_velocity(fresh):.3f}"
            f" m/s (from {min(fresh):.3f} to {max(fresh):.3f}; training figure {training:.3f})")


MEANING = ("training: the best of its generation, on the noise it was scored with;\n"
           "re-run: what that robot does on the same ground (the video is one such run);\n"
           "validation: hills it never trained on, so lower.")
