"""``somite gait``: what a robot does, per voxel and in one line of words."""

from __future__ import annotations

import argparse

from ..experiments.origin import origin_of
from ._progress import simulating
from .common import (
    GENOME_RUN,
    add_options,
    add_simulation_options,
    check_episodes,
    load_genome,
    print_json,
    settings_line,
    simulation_config,
    warn_whole_episode,
)
from .show import DEFAULT_TERRAIN, add_terrain

HELP = ("Simulate a genome (file or run directory) and summarise its gait: per voxel the "
        "actuation's frequency, swing, phase and ground contact, and one line of words.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_terrain(parser)
    add_simulation_options(parser, layered=GENOME_RUN)
    parser.add_argument("--picture", default=None, metavar="PATH",
                        help="also draw the actuation heat map and spectra (.png or .svg)")
    add_options(parser, "json", "yes", "genome")


def run(args: argparse.Namespace) -> int:
    from ..analysis.gait import analyse_gait
    from ..viz.video import record_episode

    if args.picture is not None:
        from ..viz.gait import GAIT_FORMATS
        from ..viz.output import check_output

        check_output(args.picture, GAIT_FORMATS)
    genome = load_genome(args.genome)
    origin = origin_of(args.genome)
    terrain = args.terrain or origin.fixed_terrain() or DEFAULT_TERRAIN
    config = simulation_config(args, origin)
    check_episodes(1, config, genome.body, args.yes, "the episode")
    if not args.json:
        print(settings_line(args, config, origin, terrain))
    # Progress on stderr, as every command's; with --json stdout stays the JSON alone.
    with simulating(f"simulating {config.duration:g} s on {terrain}"):
        recording = record_episode(genome.body, genome, terrain, config, args.seed)
    gait = analyse_gait(recording)
    if args.picture is not None:
        from ..viz.gait import draw_gait

        draw_gait(gait, recording, args.picture)
    if args.json:
        print_json({"shape": genome.body.shape.grid_string(), "terrain": recording.terrain.name,
                    **gait.to_dict()})
        return 0
    print(f"{genome.body.shape.grid_string()} on {recording.terrain.name}, analysed over "
          f"[{gait.start:g} s, {gait.end:g} s]")
    print(gait.table())
    print(f"main actuation frequency {gait.frequency:.2f} Hz; centre of mass stride frequency "
          f"{gait.stride_frequency:.2f} Hz; still voxels: "
          f"{', '.join(map(str, gait.still)) or 'none'}")
    print(f"gait: {gait.description}")
    if args.picture is not None:
        print(f"wrote {args.picture}")
    warn_whole_episode(args.prog, config)
    return 0
