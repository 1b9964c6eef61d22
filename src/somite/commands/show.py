"""``somite show``: watch a robot, as a video or a time-lapse strip (paper Figures 1 and 4)."""

from __future__ import annotations

import argparse
import sys

from ..errors import bad
from ..experiments.origin import origin_of
from ..limits import MAX_FRAMES, at_most
from ..sim.config import CONTROL_HZ
from ..sim.terrain import TERRAIN_HELP
from ..viz.frame import frame_steps
from ..viz.output import check_output
from ..viz.video import (
    DEFAULT_STRIP_FRAMES,
    OUTPUT_FORMATS,
    STRIP_FORMATS,
    TILE_SIZE,
    VIDEO_SIZE,
    frame_size,
    record_episode,
    write_episode,
)
from ._progress import rendering, simulating
from .common import (
    GENOME_RUN,
    add_options,
    add_simulation_options,
    finite_float,
    load_genome,
    settings_line,
    simulation_config,
    warn_whole_episode,
    whole_int,
)

DEFAULT_TERRAIN = "hilly-1-10-0"
"""Where a robot is shown when neither ``--terrain`` nor a fixed training terrain says."""

HELP = "Simulate a genome (file or run directory) and write an MP4/GIF video or a PNG strip."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--terrain", default=None,
                        help=f"{TERRAIN_HELP} (default: the run's training terrain when it was "
                        f"one fixed terrain, else {DEFAULT_TERRAIN})")
    add_simulation_options(parser, layered=GENOME_RUN)
    parser.add_argument("--out", default=None,
                        help="walk.mp4 or walk.gif (video), strip.png (time-lapse); "
                        "default walk.mp4, or strip.png with --frames")
    parser.add_argument("--frames", type=whole_int("frames"), default=None,
                        help=f"tiles of a .png time-lapse (default {DEFAULT_STRIP_FRAMES})")
    parser.add_argument("--brain", action="store_true", help="draw the controller on the body")
    parser.add_argument("--fps", type=finite_float("fps"), default=30.0,
                        help="video frames per second, at most 60 (30: every other step)")
    parser.add_argument("--width", type=whole_int("width"), default=None,
                        help="video width (960) or tile width (320) [px]")
    parser.add_argument("--height", type=whole_int("height"), default=None,
                        help="video height (540) or tile height (240) [px]")
    add_options(parser, "yes", "genome")


def run(args: argparse.Namespace) -> int:
    out = args.out or ("strip.png" if args.frames is not None else "walk.mp4")
    out = check_output(out, OUTPUT_FORMATS)
    if args.frames is not None:
        if out.suffix.lower() not in STRIP_FORMATS:
            raise bad("frames", args.frames, "a time-lapse strip is a .png; drop --frames")
        if args.frames < 1:
            raise bad("frames", args.frames, "must be at least 1")
        at_most("frames", args.frames, MAX_FRAMES)
    # Check what can be checked before a simulation that may take a while.
    frame_steps(1, args.fps)
    strip = out.suffix.lower() in STRIP_FORMATS
    width, height = frame_size(args.width, args.height, TILE_SIZE if strip else VIDEO_SIZE)
    genome = load_genome(args.genome)
    origin = origin_of(args.genome)
    terrain = args.terrain or origin.fixed_terrain() or DEFAULT_TERRAIN
    config = simulation_config(args, origin)
    frames = (args.frames or DEFAULT_STRIP_FRAMES) if strip else len(
        frame_steps(config.n_steps, args.fps))
    _check_drawing(out, frames, width * height, config, genome.body, args.yes)
    print(settings_line(args, config, origin, terrain))
    with simulating(f"simulating {config.duration:g} s on {terrain}"):
        recording = record_episode(genome.body, genome, terrain, config, args.seed)
    if not recording.complete:
        stop = recording.n_steps / CONTROL_HZ
        print(f"somite show: note: the simulation went non-finite after t = {stop:.2f} s; "
              "the output stops there", file=sys.stderr)
    with rendering(f"drawing {out.name}") as progress:
        write_episode(recording, out, args.fps, args.width, args.height,
                      genome if args.brain else None, args.frames, progress)
    start = config.transient_steps / CONTROL_HZ
    print(f"wrote {out}: {genome.body.shape.grid_string()} on {recording.terrain.name}, "
          f"{config.duration:g} s, v_x = {recording.velocity:.3f} m/s "
          f"(over [{start:g} s, {config.duration:g} s])")
    warn_whole_episode(args.prog, config)  # last: a caveat on the result
    return 0



def _check_drawing(out, frames: int, pixels: int, config, body, yes: bool) -> None:
    """Refuse a drawing that would take more than the budget's hours (simulating and drawing
    every frame) or whose held frames (a GIF's, a strip's tiles) would not fit in memory."""
    from ..budget import BYTES_PER_HELD_PIXEL, PIXELS_PER_SECOND, check_memory, check_time, hours

    drawing = float(frames) * pixels / PIXELS_PER_SECOND / 3600
    check_time(f"drawing {out.name}", hours(config.n_steps, body.shape.n_voxels, 1) + drawing,
               yes)
    if out.suffix.lower() in (".gif", ".png"):
        check_memory(f"the {frames} frames of {out.name}",
                     float(frames) * pixels * BYTES_PER_HELD_PIXEL)
