"""``somite reoptimize``: re-evolve a (reassembled) genome and track its transferability."""

from __future__ import annotations

import argparse
import math

from ..experiments.reoptimize import reoptimize
from ..experiments.runner import RunDirectory
from ..tasks.backends import check_backend
from ..tasks.validation import check_count
from ..tasks.velocity import mean_velocity
from .common import add_genome, add_options, load_genome
from .evolve import add_evolution_options, configuration, progress_bar, summarise

HELP = ("Re-optimise a genome with the EA from it and its mutants (510 generations in the "
        "paper); writes the run and transfer.csv (rho per generation).")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_genome(parser, role="the genome to start from (e.g. reassembled.json)")
    parser.add_argument("--donors", nargs="+", default=(),
                        help="donor genomes: rho = v_x / mean v_x of the donors")
    add_options(parser, "validation", notes={"validation": "rho is measured on them"})
    add_evolution_options(parser)
    parser.set_defaults(generations=510)


def run(args: argparse.Namespace) -> int:
    check_count(args.validation)
    genome = load_genome(args.genome)
    donors = [load_genome(path) for path in args.donors]
    shape = genome.body.shape.grid_string()
    config = configuration(args, shape=shape, start=str(args.genome))
    backend = check_backend(args.backend)
    # Locked before the progress bar starts, so that a refusal is the only line printed.
    with RunDirectory(args.out).locked() as run_dir:
        with progress_bar(config.generations, args.quiet) as report:
            ea, rows, velocities = reoptimize(config, run_dir, genome, donors,
                                              args.validation, resume=args.resume,
                                              force=args.force, progress=report,
                                              backend=backend)
    summarise(ea, RunDirectory(args.out), args.quiet)
    donors_mean = mean_velocity(velocities) if donors else math.nan
    if not args.quiet and donors:
        print(f"rho: {rows[0]['rho']:.3f} at the start, {rows[-1]['rho']:.3f} at the end "
              f"(donors {donors_mean:.3f} m/s on {args.validation} validation terrains)")
    return 0
