"""``somite simulate``: one robot, one episode, its outcome."""

from __future__ import annotations

import argparse

from ..brain.controllers import parse_controller
from ..sim.body import Body
from ..sim.terrain import TERRAIN_HELP, parse_terrain
from ..tasks.backends import check_backend
from ..tasks.locomotion import simulate
from .common import (
    NON_FINITE,
    add_options,
    add_simulation_options,
    print_json,
    simulation_config,
    warn,
)

HELP = "Simulate one robot and print how it went (v_x over [5 s, end], distance, ...)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "shape", "sensors")
    parser.add_argument("--terrain", default="flat", help=TERRAIN_HELP)
    parser.add_argument(
        "--controller", default="sine", help="zero, or sine:freq=F,amp=A,phase=P (1, 1, -1)"
    )
    add_simulation_options(parser)
    add_options(parser, "backend", "json")


def run(args: argparse.Namespace) -> int:
    body = Body.build(args.shape, args.sensors)
    terrain = parse_terrain(args.terrain)
    controller = parse_controller(args.controller)
    config = simulation_config(args)
    [outcome], _ = simulate([body], [terrain], [controller], config, seeds=args.seed,
                            backend=check_backend(args.backend))
    report = {
        "shape": body.shape.grid_string(),
        "terrain": terrain.name,
        "controller": args.controller,
        "duration": config.duration,
        "seed": args.seed,
        **outcome.to_dict(),
    }
    if args.json:
        print_json(report)
    else:
        for key, value in report.items():
            if isinstance(value, float):
                value = f"{value:.4f}"
            elif isinstance(value, list):
                value = ", ".join(f"{v:.3f}" for v in value)
            print(f"{key:>21}: {value}")
    if outcome.non_finite:
        warn(args.prog, f"at {outcome.non_finite} control steps {NON_FINITE}")
    return 0 if outcome.finite else 1
