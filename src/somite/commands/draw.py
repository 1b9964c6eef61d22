"""``somite draw``: a controller on its body at rest (paper Figures 6 and 12)."""

from __future__ import annotations

import argparse

from ..experiments.lock import lock_if_run
from ..experiments.runner import MANIFEST, RUN_FILES
from ..sim.partition import Partition
from ..viz.brain import BRAIN_FORMATS, draw_brain
from ..viz.output import check_output
from .common import add_options, load_genome

HELP = "Draw a genome's graph on its body (PNG or SVG), optionally coloured by modules."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "genome")
    parser.add_argument("--out", default="brain.png", help="brain.png or brain.svg")
    parser.add_argument("--partition", default=None,
                        help="worm-halves, biped-legs, paper, a label grid like AAABBB/AAABBB "
                        "or a partition.json (somite discover writes one)")


def run(args: argparse.Namespace) -> int:
    out = check_output(args.out, BRAIN_FORMATS)
    genome = load_genome(args.genome)
    partition = None
    if args.partition is not None:
        partition = Partition.parse(args.partition, genome.body.shape)
    # Into a run directory, only with its lock: a running run there refuses the command.
    with lock_if_run(out.parent, (*RUN_FILES, MANIFEST)):
        drawing = draw_brain(genome, out, partition)
    summary = f"wrote {out}: {genome.n_nodes} nodes, {genome.n_edges} edges"
    if partition is not None:
        n_cut = sum(edge.cut for edge in drawing.edges)
        summary += f", {n_cut} cut by the {len(partition.modules)} modules"
    print(summary)
    return 0
