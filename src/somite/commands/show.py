"""``somite show``: watch a robot, as a video, a time-lapse strip (paper Figures 1 and 4) or a
replay page for the browser (one or several robots), with a summary of its gait."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ..analysis.gait import analyse_gait
from ..errors import bad
from ..experiments.origin import origin_of
from ..limits import MAX_FRAMES, at_most
from ..sim.config import CONTROL_HZ
from ..sim.terrain import TERRAIN_HELP
from ..viz.frame import check_speed, frame_steps
from ..viz.output import check_output
from ..viz.replay import REPLAY_FORMATS
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

HELP = ("Simulate a genome (file or run directory) and write an MP4/GIF video, a PNG strip or "
        "an HTML replay page (several genomes: one page to compare them); prints its gait.")
SHOW_FORMATS = OUTPUT_FORMATS + REPLAY_FORMATS


def add_terrain(parser: argparse.ArgumentParser) -> None:
    """``--terrain``, defaulting to the genome's run's fixed terrain (``somite show``, ``gait``)."""
    parser.add_argument("--terrain", default=None,
                        help=f"{TERRAIN_HELP} (default: the run's training terrain when it was "
                        f"one fixed terrain, else {DEFAULT_TERRAIN})")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_terrain(parser)
    add_simulation_options(parser, layered=GENOME_RUN)
    parser.add_argument("--out", default=None,
                        help="walk.mp4 or walk.gif (video), strip.png (time-lapse), walk.html "
                        "(a replay page: one file, no server; the only output for several "
                        "genomes); default walk.mp4, or strip.png with --frames")
    parser.add_argument("--frames", type=whole_int("frames"), default=None,
                        help=f"tiles of a .png time-lapse (default {DEFAULT_STRIP_FRAMES})")
    parser.add_argument("--brain", action="store_true", help="draw the controller on the body")
    parser.add_argument("--fps", type=finite_float("fps"), default=30.0,
                        help="video frames per second, at most 60 (30: every other step)")
    parser.add_argument("--speed", type=finite_float("speed"), default=1.0,
                        help="playback speed of a video or replay page, 0.05 to 4 times real "
                        "time (0.25: slow motion, a video 4 times as long)")
    parser.add_argument("--width", type=whole_int("width"), default=None,
                        help="video width (960) or tile width (320) [px]")
    parser.add_argument("--height", type=whole_int("height"), default=None,
                        help="video height (540) or tile height (240) [px]")
    add_options(parser, "yes")
    parser.add_argument("genome", nargs="+",
                        help="genome JSON, or a run directory (its best.json); several for one "
                        "replay page (.html) that compares them")


def run(args: argparse.Namespace) -> int:
    out = args.out or ("strip.png" if args.frames is not None else "walk.mp4")
    out = check_output(out, SHOW_FORMATS)
    page = out.suffix.lower() in REPLAY_FORMATS
    if len(args.genome) > 1 and not page:
        raise bad("genome", " ".join(args.genome), "several genomes make one replay page; "
                  "use --out NAME.html")
    if args.frames is not None:
        if out.suffix.lower() not in STRIP_FORMATS:
            raise bad("frames", args.frames, "a time-lapse strip is a .png; drop --frames")
        if args.frames < 1:
            raise bad("frames", args.frames, "must be at least 1")
        at_most("frames", args.frames, MAX_FRAMES)
    # Check what can be checked before a simulation that may take a while.
    frame_steps(1, args.fps)
    check_speed(args.speed)
    strip = out.suffix.lower() in STRIP_FORMATS
    width, height = frame_size(args.width, args.height, TILE_SIZE if strip else VIDEO_SIZE)
    genomes = [load_genome(path) for path in args.genome]
    origins = [origin_of(path) for path in args.genome]
    # One ground for every robot on a page: the first's, so that they can be compared.
    terrain = args.terrain or origins[0].fixed_terrain() or DEFAULT_TERRAIN
    configs = [simulation_config(args, origin) for origin in origins]
    for genome, config in zip(genomes, configs):
        held = drawn = 0  # a page is drawn by the browser
        if strip:
            held = drawn = args.frames or DEFAULT_STRIP_FRAMES
        elif not page:
            # In slow motion a step shown by several frames is drawn once, held in each.
            steps = frame_steps(config.n_steps, args.fps, args.speed)
            held, drawn = len(steps), len(np.unique(steps))
        _check_drawing(out, held, drawn, width * height, config, genome.body, args.yes)
    runs = []
    for path, genome, origin, config in zip(args.genome, genomes, origins, configs):
        print(settings_line(args, config, origin, terrain))
        with simulating(f"simulating {config.duration:g} s on {terrain}"):
            recording = record_episode(genome.body, genome, terrain, config, args.seed)
        if not recording.complete:
            stop = recording.n_steps / CONTROL_HZ
            print(f"somite show: note: the simulation went non-finite after t = {stop:.2f} s; "
                  "the output stops there", file=sys.stderr)
        runs.append((path, genome, recording, analyse_gait(recording)))
    if page:
        from ..viz.replay import ReplayRun, write_replay

        write_replay([ReplayRun(rec, genome, _label(path), gait.description)
                      for path, genome, rec, gait in runs], out,
                     title=f"somite replay: {', '.join(_label(p) for p, *_ in runs)}",
                     speed=args.speed)
    else:
        _, genome, recording, _ = runs[0]
        with rendering(f"drawing {out.name}") as progress:
            write_episode(recording, out, args.fps, args.width, args.height,
                          genome if args.brain else None, args.frames, progress, args.speed)
    for path, genome, recording, gait in runs:
        config = recording.config
        start = config.transient_steps / CONTROL_HZ
        what = f"wrote {out}" if len(runs) == 1 else f"{_label(path)}"
        print(f"{what}: {genome.body.shape.grid_string()} on {recording.terrain.name}, "
              f"{config.duration:g} s, v_x = {recording.velocity:.3f} m/s "
              f"(over [{start:g} s, {config.duration:g} s])")
        print(f"gait: {gait.description}")
    if len(runs) > 1:
        print(f"wrote {out}")
    warn_whole_episode(args.prog, configs[0])  # last: a caveat on the result
    return 0


def _label(path: str) -> str:
    """A genome's name on a page: its run directory's, or its file's."""
    from pathlib import Path

    target = Path(path)
    return target.name if target.is_dir() else target.stem


def _check_drawing(out, frames: int, drawn: int, pixels: int, config, body, yes: bool) -> None:
    """Refuse a drawing that would take more than the budget's hours (simulating and drawing
    ``drawn`` frames) or whose held ``frames`` (a GIF's, a strip's tiles) would not fit in
    memory."""
    from ..budget import BYTES_PER_HELD_PIXEL, PIXELS_PER_SECOND, check_memory, check_time, hours

    drawing = float(drawn) * pixels / PIXELS_PER_SECOND / 3600
    check_time(f"drawing {out.name}", hours(config.n_steps, body.shape.n_voxels, 1) + drawing,
               yes)
    if out.suffix.lower() in (".gif", ".png"):
        check_memory(f"the {frames} frames of {out.name}",
                     float(frames) * pixels * BYTES_PER_HELD_PIXEL)
