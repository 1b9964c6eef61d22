"""``somite simulate``: one robot, one episode, its outcome."""

from __future__ import annotations

import argparse
import math

import numpy as np

from .._io import read_text
from ..brain.compile import compile_genome
from ..brain.control import CONTROLLER_HELP, parse_controller
from ..brain.controllers import Table
from ..errors import bad
from ..experiments.origin import origin_of
from ..sim.body import Body
from ..sim.terrain import TERRAIN_HELP, parse_terrain
from ..tasks.backends import check_backend
from ..tasks.locomotion import OUTCOME_UNITS, simulate_batch
from ._progress import simulating
from .common import (
    GENOME_RUN,
    NON_FINITE,
    add_options,
    add_simulation_options,
    load_genome,
    option,
    print_json,
    settings_line,
    simulation_config,
    warn,
    warn_whole_episode,
)

HELP = "Simulate one robot and print how it went (v_x over [5 s, end], distance, ...)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "shape", "sensors", layered="--genome's")
    parser.add_argument("--terrain", default="flat", help=TERRAIN_HELP)
    parser.add_argument(
        "--controller", default=None,
        help=f"{CONTROLLER_HELP} (default: --genome's, else sine)",
    )
    parser.add_argument("--genome", default=None,
                        help="simulate this genome (a genome JSON or a run directory): its body "
                        "and controller, and its run's duration and preset unless given")
    parser.add_argument("--actions", default=None, metavar="FILE.csv",
                        help="replay these actuations: one row a control step, one column a "
                        "voxel, comma-separated (row i is actuation i, from row 0 again past the last; the "
                        "first row 0 is never in force: "
                        "the actions of a somite/Locomotion-v0 episode replay bit for bit, "
                        "written with 17 significant digits)")
    add_simulation_options(parser, layered=GENOME_RUN)
    add_options(parser, "backend", "json")


def read_actions(path: str) -> np.ndarray:
    """The (steps, voxels) actuation table of the CSV file ``path``, or a one-line error
    naming the file, the line and the cell."""
    rows = []
    for number, line in enumerate(read_text(path, "actions").splitlines(), start=1):
        if not line.strip():
            continue
        cells = line.split(",")
        try:
            row = [float(cell) for cell in cells]
        except ValueError:
            raise bad("actions", f"{path}, line {number}", "expected numbers separated by "
                      "commas") from None
        if rows and len(row) != len(rows[0]):
            raise bad("actions", f"{path}, line {number}",
                      f"has {len(row)} columns, the first row {len(rows[0])}")
        wrong = [v for v in row if not (math.isfinite(v) and -1.0 <= v <= 1.0)]
        if wrong:
            raise bad("actions", f"{path}, line {number}",
                      f"actuation must be finite and in [-1, 1], not {wrong[0]!r}")
        rows.append(row)
    if not rows:
        raise bad("actions", path, "has no rows")
    return np.array(rows, dtype=np.float64)


def run(args: argparse.Namespace) -> int:
    origin = None
    if args.genome is not None:
        for name in ("shape", "sensors", "controller"):
            if getattr(args, name) is not None:
                raise bad(name, getattr(args, name), "a --genome brings its own; drop one")
        genome = load_genome(args.genome)
        origin = origin_of(args.genome)
        body, controller = genome.body, compile_genome(genome)
    else:
        body = Body.build(option(args, "shape"), option(args, "sensors"))
        controller = parse_controller(args.controller or "sine")
    if args.actions is not None:
        for name in ("controller", "genome"):
            if getattr(args, name) is not None:
                raise bad(name, getattr(args, name), "--actions are the controller; drop one")
        table = read_actions(args.actions)
        if table.shape[1] != body.shape.n_voxels:
            raise bad("actions", args.actions, f"has {table.shape[1]} columns, the body "
                      f"{body.shape.n_voxels} voxels")
        controller = Table(table)
    terrain = parse_terrain(args.terrain)
    config = simulation_config(args, origin)
    if not args.json and origin is not None and origin.source:
        print(settings_line(args, config, origin, terrain.name))
    backend = check_backend(args.backend)
    with simulating(f"simulating {config.duration:g} s", backend=backend):
        [outcome], _ = simulate_batch([body], [terrain], [controller], config, seeds=args.seed,
                                      backend=backend)
    report = {
        "shape": body.shape.grid_string(),
        "terrain": terrain.name,
        "controller": (args.genome if args.genome is not None else
                       f"actions {args.actions}" if args.actions is not None else
                       args.controller or "sine"),
        "duration": config.duration,
        "seed": args.seed,
        **outcome.to_dict(),
    }
    units = {"duration": ("s", "the episode's length"),
             "seed": ("", "the seed of the sensor noise"), **OUTCOME_UNITS}
    if args.json:
        print_json({**report, "units": {key: units[key][0] for key in units}})
    else:
        start, end = config.measured_interval
        for key, value in report.items():
            if isinstance(value, float):
                value = f"{value:.4f}"
            elif isinstance(value, list):
                value = ", ".join(f"{v:.3f}" for v in value)
            unit, meaning = units.get(key, ("", ""))
            meaning = meaning.replace("[transient, end]", f"[{start:g} s, {end:g} s]")
            shown = f"{key:>21}: {value} {unit}".rstrip()
            print(f"{shown:<38}  {meaning}" if meaning else shown)
    if outcome.non_finite:
        warn(args.prog, f"at {outcome.non_finite} control steps {NON_FINITE}")
    warn_whole_episode(args.prog, config)  # last: a caveat on the result
    return 0 if outcome.finite else 1
