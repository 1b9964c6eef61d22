"""``somite reoptimize``: re-evolve a (reassembled) genome and track its transferability."""

from __future__ import annotations

import argparse
import math

from ..experiments.origin import origin_of, shared_origin
from ..experiments.reoptimize import reoptimize
from ..experiments.runner import RunDirectory
from ..modules.transfer import RHO_FLOOR
from ..tasks.backends import check_backend
from ..tasks.validation import check_count
from ..tasks.velocity import mean_velocity
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
    add_evolution_options(parser, generations=REOPTIMIZE_GENERATIONS,
                          terrain="the genome's run's (a reassembly's: its donors' runs'), else "
                          "the one the --donors' runs shared, else hilly-1-10-rnd")
    parser.set_defaults(generations=REOPTIMIZE_GENERATIONS)


REOPTIMIZE_GENERATIONS = 510
"""The paper's re-optimisation length (section 6)."""


def run(args: argparse.Namespace) -> int:
    check_count(args.validation)
    genome = load_genome(args.genome)
    donors = [load_genome(path) for path in args.donors]
    shape = genome.body.shape.grid_string()
    origin = origin_of(args.genome)
    # The training terrain: given, else the genome's run's (a reassembly's: its donors'),
    # else the one the --donors' runs shared, else the default; the settings line says which.
    terrain, terrain_from = origin.terrain, origin.source
    if terrain is None:
        donors_origin = shared_origin(args.donors)
        terrain, terrain_from = donors_origin.terrain, donors_origin.source
    inherited = {**origin.options(), **({"terrain": terrain} if terrain else {})}
    if genome.delay_per_voxel:  # its offspring keep the delays it was evolved with
        inherited["delay_per_voxel"] = genome.delay_per_voxel
    config = configuration(args, defaults=inherited, shape=shape, start=str(args.genome))
    check_run_work(config, genome.body.shape.n_voxels, args.yes, "this re-optimisation")
    backend = check_backend(args.backend)
    # Locked before anything is printed, so that a refusal is the only line.
    with RunDirectory(args.out).locked() as run_dir:
        if not args.quiet:
            print(settings(args, config, origin, terrain, terrain_from))
        with progress_bar(config.generations, args.quiet, backend) as report:
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


def settings(args: argparse.Namespace, config, origin, terrain, terrain_from: str) -> str:
    """The settings line: what the re-optimisation runs with, and where each came from
    (``terrain``, ``terrain_from``: the inherited training terrain and its source, or None)."""
    if args.resume:
        where = "as the run was started"
    elif args.terrain is not None:
        where = "as given"
    elif terrain is not None and config.terrain == terrain:
        where = f"from {terrain_from}"
    elif args.config:
        where = "from --config"
    else:
        where = "the default: no run to inherit it from"
    text = (f"settings: training on {config.terrain} ({where}), {config.duration:g} s (v_x "
            f"over [{config.transient:g} s, {config.duration:g} s]), preset {config.preset}, "
            f"rho on {args.validation} validation terrains")
    if origin.source:
        text += f"; duration and preset from {origin.source} where not given"
    return text
