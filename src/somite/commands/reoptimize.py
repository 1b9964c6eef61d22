"""``somite reoptimize``: re-evolve a (reassembled) genome and track its transferability."""

from __future__ import annotations

import argparse
import math

from ..experiments.origin import origin_of
from ..experiments.reoptimize import reoptimize
from ..experiments.runner import RunDirectory
from ..modules.transfer import RHO_FLOOR
from ..tasks.backends import check_backend
from ..tasks.validation import check_count
from ..tasks.velocity import mean_velocity
from ._progress import note_compiling
from .common import (
    add_genome,
    add_options,
    check_run_work,
    load_genome,
    warn,
    warn_whole_episode,
)
from .evolve import add_evolution_options, configuration, progress_bar, summarise

HELP = ("Re-optimise a genome with the EA from it and its mutants (510 generations in the "
        "paper); writes the run and transfer.csv (rho per generation).")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_genome(parser, role="the genome to start from (e.g. reassembled.json)")
    parser.add_argument("--donors", nargs="+", default=(),
                        help="donor genomes: rho = v_x / mean v_x of the donors")
    add_options(parser, "validation", notes={"validation": "rho is measured on them"})
    add_evolution_options(parser, generations=REOPTIMIZE_GENERATIONS)
    parser.set_defaults(generations=REOPTIMIZE_GENERATIONS)


REOPTIMIZE_GENERATIONS = 510
"""The paper's re-optimisation length (section 6)."""


def run(args: argparse.Namespace) -> int:
    check_count(args.validation)
    genome = load_genome(args.genome)
    donors = [load_genome(path) for path in args.donors]
    shape = genome.body.shape.grid_string()
    origin = origin_of(args.genome)
    inherited = {**origin.options(), **({"terrain": origin.terrain} if origin.terrain else {})}
    config = configuration(args, defaults=inherited, shape=shape, start=str(args.genome))
    check_run_work(config, genome.body.shape.n_voxels, args.yes, "this re-optimisation")
    backend = check_backend(args.backend)
    # Locked before anything is printed, so that a refusal is the only line.
    with RunDirectory(args.out).locked() as run_dir:
        if not args.quiet:
            print(f"settings: training on {config.terrain}, {config.duration:g} s (v_x over "
                  f"[{config.transient:g} s, {config.duration:g} s]), preset {config.preset}, "
                  f"rho on {args.validation} validation terrains"
                  + (f"; from {origin.source} where not given" if origin.source else ""))
        note_compiling(args.quiet, backend)
        with progress_bar(config.generations, args.quiet) as report:
            ea, rows, velocities = reoptimize(config, run_dir, genome, donors,
                                              args.validation, resume=args.resume,
                                              force=args.force, progress=report,
                                              backend=backend,
                                              force_physics=args.force_physics)
    summarise(ea, RunDirectory(args.out), args.quiet)
    donors_mean = mean_velocity(velocities) if donors else math.nan
    if not args.quiet and donors:
        print(f"rho: {rows[0]['rho']:.3f} at the start, {rows[-1]['rho']:.3f} at the end "
              f"(donors {donors_mean:.3f} m/s on {args.validation} validation terrains)")
    if donors and abs(donors_mean) < RHO_FLOOR:
        warn(args.prog, f"the donors' mean v_x is {donors_mean:.3f} m/s, below "
             f"{RHO_FLOOR:g} m/s: rho divides by it and means little")
    warn_whole_episode(args.prog, config.setup.sim)  # last: a caveat on the result
    return 0
