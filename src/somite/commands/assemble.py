"""``somite assemble``: build a new robot from library modules placed on a grid."""

from __future__ import annotations

import argparse
import json

from .._io import check_output_folder, make_folder, write_atomic
from ..errors import bad
from ..experiments.origin import shared_origin
from ..modules.library import assemble, list_library, parse_placement
from .common import (
    add_options,
    add_simulation_options,
    check_episodes,
    option,
    settings_line,
    simulation_config,
    warn_whole_episode,
    whole_int,
)

HELP = "Assemble a robot from library modules placed at grid offsets (NAME@X,Y)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("library", nargs="+", help="library folder(s) and/or module files")
    parser.add_argument(
        "--place", action="append", required=True, metavar="NAME@X,Y",
        help="put module NAME with its bounding-box corner at cell (X, Y); repeat per module",
    )
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument(
        "--evaluate", type=whole_int("evaluate"), default=0, metavar="N",
        help="also measure v_x on N validation terrains (default 0: no simulation)",
    )
    add_simulation_options(parser, layered="the modules' donors' runs' (when all agree)")
    add_options(parser, "yes")


def run(args: argparse.Namespace) -> int:
    out = check_output_folder(args.out)
    if args.evaluate < 0:
        raise bad("evaluate", args.evaluate, "must be 0 or more")
    library = list_library(args.library)
    placements = [
        parse_placement(text, library, f"place[{i}]") for i, text in enumerate(args.place)
    ]
    # The donors' runs, as their module files name them (found from here), lend duration and
    # preset when they all ran with the same.
    origin = shared_origin([p.module.provenance.donor for p in placements
                            if p.module.provenance.donor]) if args.evaluate else None
    config = simulation_config(args, origin) if args.evaluate else None
    genome = assemble(placements)
    if config is not None:
        check_episodes(args.evaluate, config, genome.body, args.yes, "this evaluation")
    evaluation = None
    if args.evaluate:
        from ._progress import simulating

        print(settings_line(args, config, origin, f"{args.evaluate} validation terrains"))
        with simulating(f"measuring it on {args.evaluate} validation terrains"):
            evaluation = _evaluate(args, genome, config, option(args, "preset",
                                                                 origin.options()))
    make_folder(out)
    genome.save(out / "assembled.json")
    if evaluation is not None:
        text = json.dumps(evaluation, indent=1, allow_nan=False) + "\n"
        write_atomic(out / "evaluation.json", text)
    print(
        f"assembled {genome.body.shape.grid_string()}: {genome.n_nodes} nodes, "
        f"{genome.n_edges} edges -> {out / 'assembled.json'}"
    )
    if evaluation is not None:
        v = evaluation["v_x"]
        print(f"  v_x {'n/a' if v is None else f'{v:.3f}'} m/s on {args.evaluate} terrains")
    if config is not None:
        warn_whole_episode(args.prog, config)  # last: a caveat on the result
    return 0


def _evaluate(args, genome, config, preset: str) -> dict:
    import math

    from ..tasks.validation import evaluate, validation_terrains
    from ..tasks.velocity import mean_velocity

    terrains = validation_terrains(args.evaluate)
    velocity = evaluate([genome], terrains, config, args.seed)[0]
    mean = mean_velocity(velocity)
    return {
        "genome": "assembled.json",
        "placements": list(args.place),
        "terrains": [t.name for t in terrains],
        "duration": config.duration,
        "preset": preset,
        "seed": args.seed,
        "v_x": mean if math.isfinite(mean) else None,
        "per_terrain": [float(v) if math.isfinite(v) else None for v in velocity],
    }
