"""``somite evaluate``: re-run a saved genome on fixed terrains and report v_x."""

from __future__ import annotations

import argparse

import numpy as np

from ..errors import bad
from ..experiments.origin import origin_of
from ..sim.terrain import parse_terrain
from ..tasks.locomotion import OUTCOME_UNITS
from ..tasks.validation import evaluate_outcomes, fresh_terrains, validation_terrains
from ..tasks.velocity import mean_velocity
from ._progress import simulating
from .common import (
    GENOME_RUN,
    NON_FINITE,
    add_options,
    add_simulation_options,
    check_episodes,
    load_genome,
    option,
    print_json,
    settings_line,
    simulation_config,
    warn,
    warn_whole_episode,
    whole_int,
)

HELP = ("Evaluate a genome (file or run directory) on its run's terrain, the validation "
        "terrains or fresh ones; per-terrain v_x.")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "genome", "validation",
                notes={"validation": "used when no --terrain is given and the run did not "
                       "train on one fixed terrain"})
    parser.add_argument("--terrain", action="append", dest="terrains",
                        help="terrain name (repeatable); default: the run's training terrain "
                        "when it was one fixed terrain (e.g. flat), else the validation "
                        "terrains")
    parser.add_argument("--fresh", type=whole_int("fresh"), metavar="N",
                        help="the first N fresh terrains instead (hilly-1-10-20000 on: "
                        "neither training nor validation terrains, as in somite report)")
    add_simulation_options(parser, layered=GENOME_RUN)
    add_options(parser, "json", "yes")


def run(args: argparse.Namespace) -> int:
    genome = load_genome(args.genome)
    origin = origin_of(args.genome)
    if args.fresh is not None:
        if args.terrains:
            raise bad("fresh", args.fresh, "give --fresh or --terrain, not both")
        terrains = fresh_terrains(args.fresh)
        where = f"{len(terrains)} fresh terrains ({terrains[0].name} on)"
    elif args.terrains:
        terrains = [parse_terrain(name) for name in args.terrains]
        where = ", ".join(args.terrains)
    elif origin.fixed_terrain() is not None:
        terrains = [parse_terrain(origin.fixed_terrain())]
        where = f"the run's terrain {origin.fixed_terrain()}"
    else:
        if args.validation < 1:
            raise bad("validation", args.validation, "must be at least 1")
        terrains = validation_terrains(args.validation)
        where = f"{len(terrains)} validation terrains"
    config = simulation_config(args, origin)
    check_episodes(len(terrains), config, genome.body, args.yes, "this evaluation")
    settings = settings_line(args, config, origin, where)
    with simulating(f"simulating {len(terrains)} episodes of {config.duration:g} s"):
        outcomes = evaluate_outcomes([genome], terrains, config, args.seed)[0]
    velocities = np.array([o.velocity for o in outcomes])
    mean = mean_velocity(velocities)  # NaN when any terrain is (the one rule)
    report = {
        "genome": args.genome,
        "settings": {"duration": config.duration, "transient": config.transient,
                     "preset": option(args, "preset", origin.options()), "seed": args.seed,
                     "from": origin.source or None},
        "terrains": {t.name: o.velocity for t, o in zip(terrains, outcomes)},
        "mean_velocity": None if np.isnan(mean) else mean,
        # Terrains whose episode had a non-finite step (v_x NaN, or a clamped actuation).
        "non_finite": sum(1 for o in outcomes if o.non_finite or not o.finite),
        # Exploits show in numbers: an inverted voxel, a robot that moves on its side, jumps.
        "diagnostics": {
            t.name: {key: getattr(o, key) for key in DIAGNOSTICS}
            for t, o in zip(terrains, outcomes)
        },
        "non_finite_steps": {t.name: o.non_finite for t, o in zip(terrains, outcomes)},
    }
    for key, pick in DIAGNOSTICS.items():
        values = [getattr(o, key) for o in outcomes]
        report[key] = float(pick(values)) if np.isfinite(values).any() else None
    # A diagnostic at the top is the worst terrain's, not a mean: said in the file, as it was
    # once read as the share of all steps.
    report["over_terrains"] = {key: OVER_TERRAINS[pick] for key, pick in DIAGNOSTICS.items()}
    if args.json:
        print_json({**report, "units": UNITS})
    else:
        print(settings)
        for t, o in zip(terrains, outcomes):
            print(f"{t.name:>22}: {o.velocity:8.4f} m/s   tilt {o.max_tilt_deg:5.1f} deg,"
                  f" on its side {o.flipped_fraction:6.1%}, area ratio >= "
                  f"{o.min_signed_area_ratio:.2f}, lowest corner {o.min_height:.2f} to "
                  f"{o.max_height:.2f} m above ground"
                  + (f", non-finite at {o.non_finite} steps" if o.non_finite else ""))
        mean = report["mean_velocity"]
        print(f"{'mean':>22}: {'NaN' if mean is None else f'{mean:8.4f}'} m/s"
              f"{'  (non-finite on some terrain)' if report['non_finite'] else ''}")
    if report["non_finite"]:
        warn(args.prog, f"on {report['non_finite']} of {len(terrains)} terrains {NON_FINITE}")
    warn_whole_episode(args.prog, config)  # last: a caveat on the result
    return 0


DIAGNOSTICS = {
    "min_signed_area_ratio": np.nanmin,
    "max_tilt_deg": np.nanmax,
    "flipped_fraction": np.nanmax,
    "max_height": np.nanmax,
    "min_height": np.nanmin,
}
"""The outcome's diagnostics, and how the report sums them up over the terrains."""

OVER_TERRAINS = {np.nanmin: "least over the terrains", np.nanmax: "most over the terrains"}
"""How ``evaluate --json`` names each of those (its ``over_terrains``)."""

UNITS = {"settings.duration": "s", "settings.transient": "s", "terrains": "m/s",
         "mean_velocity": "m/s", "non_finite": "terrains", "non_finite_steps": "control steps",
         **{key: OUTCOME_UNITS[key][0] for key in DIAGNOSTICS}}
"""The unit of every number of ``evaluate --json`` ("" for a pure number; ``diagnostics``
holds the same keys per terrain); :data:`~somite.tasks.locomotion.OUTCOME_UNITS` says what
each diagnostic is."""
