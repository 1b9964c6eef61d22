"""``somite bench``: time the episode kernel on the paper's workload, print JSON."""

from __future__ import annotations

import argparse

from ..bench import bench
from ..errors import bad
from ..limits import MAX_DURATION, MAX_POPULATION, at_most
from ..tasks.backends import check_backend
from .common import add_options, print_json, whole_int

HELP = "Time the simulation kernel (96 random ~200-element controllers, hilly, 30 s); JSON."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robots", type=whole_int("robots"), default=96, help="population size")
    add_options(parser, "duration")
    parser.add_argument("--shapes", default="worm,biped", help="comma-separated shapes")
    parser.add_argument("--no-scaling", action="store_true", help="skip the scaling runs")
    add_options(parser, "backend", "yes")


def run(args: argparse.Namespace) -> int:

    if args.robots < 4:
        raise bad("robots", args.robots, "must be at least 4")
    at_most("robots", args.robots, MAX_POPULATION)
    if not args.duration > 0:
        raise bad("duration", args.duration, "must be positive")
    at_most("duration", args.duration, MAX_DURATION)
    shapes = tuple(s for s in args.shapes.split(",") if s)
    if not shapes:
        raise bad("shapes", args.shapes, "name at least one shape")
    from ..budget import check_batch, check_steps
    from ..sim.body import Shape
    from ..sim.config import CONTROL_HZ

    voxels = max(Shape.parse(s).n_voxels for s in shapes)
    # Each population once, and the worm again at 1/4, 1/2 and all of it for the scaling.
    episodes = args.robots * (len(shapes) + (0 if args.no_scaling else 1.75))
    check_steps("this benchmark", episodes * round(args.duration * CONTROL_HZ), voxels, args.yes)
    check_batch(args.robots, voxels)
    backend = check_backend(args.backend)
    print_json(bench(shapes, args.robots, args.duration, scaling=not args.no_scaling,
                     backend=backend))
    return 0
