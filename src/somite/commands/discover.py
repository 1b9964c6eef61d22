"""``somite discover``: partition a robot around its most compact module (paper eq. 5)."""

from __future__ import annotations

import argparse

from .._io import check_output_folder
from ..experiments.discovery import (
    format_compactness,
    tie_note,
    tied_with_best,
    write_discovery,
)
from ..experiments.lock import lock_if_run
from ..experiments.runner import MANIFEST, RUN_FILES
from .common import add_options, load_genome, whole_int

HELP = "Find the most compact module of a genome (eq. 5) and partition its body around it."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "genome")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--min", dest="b_min", type=whole_int("b_min"), default=2,
                        help="b_min (default 2)")
    parser.add_argument("--max", dest="b_max", type=whole_int("b_max"), default=5,
                        help="b_max (default 5)")


def run(args: argparse.Namespace) -> int:
    out = check_output_folder(args.out)
    # Into a run directory, only with its lock: a running run there refuses the command.
    with lock_if_run(out, (*RUN_FILES, MANIFEST)):
        genome = load_genome(args.genome)
        # A b_max over the body's size is refused (b_max=13: the body has only 12 voxels),
        # not capped: the sizes printed below are then always the ones enumerated.
        best, partition, ranked = write_discovery(out, genome, str(args.genome), args.b_min,
                                                  args.b_max)
    print(f"most compact module (c = {format_compactness(best.compactness)}"
          f"{tie_note(tied_with_best(ranked))}): {list(best.voxels)}")
    print(f"partition {partition.grid_string()} ({len(partition.modules)} modules)")
    print(f"-> {out / 'partition.json'}, {out / 'candidates.csv'} ({len(ranked)} candidates: "
          f"every connected set of b_min={args.b_min} to b_max={args.b_max} voxels)")
    return 0
