"""``somite evolve``: run the paper's EA into a run directory (resumable)."""

from __future__ import annotations

import argparse
import math
import sys

from .._io import check_output_folder
from ..brain.delays import MAX_EDGE_DELAY
from ..errors import bad
from ..evolution.config import GAConfig
from ..evolution.ea import GraphEA
from ..evolution.operators import OperatorConfig
from ..experiments.config import RunConfig, load_toml, resolve
from ..experiments.runner import RunDirectory, evolve
from ..tasks.backends import check_backend
from ..tasks.distributions import DISTRIBUTION_HELP
from ..tasks.validation import VALIDATION_COUNT
from ._progress import COMPILING, Waiting, will_compile
from .common import (
    NON_FINITE,
    add_options,
    check_run_work,
    finite_float,
    warn_whole_episode,
    whole_int,
)

HELP = "Evolve a graph controller with the paper's EA; writes logs, bests and checkpoints."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "shape", "sensors", layered=_LAYERED)
    add_evolution_options(parser)


_LAYERED = "the --config file's"


def add_evolution_options(parser: argparse.ArgumentParser,
                          generations: int = RunConfig.generations,
                          terrain: str = "hilly-1-10-rnd (a new terrain per evaluation)") -> None:
    """The options shared by ``evolve`` and ``reoptimize`` (``generations``, ``terrain``: what
    their help gives as the default)."""
    parser.add_argument("--out", required=True, help="run directory")
    parser.add_argument("--config", help="TOML file with any of the options below")
    add_options(parser, "preset", layered=_LAYERED)
    parser.add_argument("--generations", type=whole_int("generations"),
                        help="generations after the initial population (default: the --config "
                        f"file's, else {generations})")
    parser.add_argument("--population", type=whole_int("population"),
                        help="robots per generation (default: the --config file's, else "
                        f"{GAConfig().population})")
    add_options(parser, "seed", layered=_LAYERED,
                notes={"seed": "seeds the whole run: variation, terrains and sensor noise"})
    parser.add_argument("--terrain", help=f"training terrains: {DISTRIBUTION_HELP}; "
                        f"default {terrain}")
    add_options(parser, "duration", layered=_LAYERED)
    parser.add_argument("--evaluations", type=whole_int("evaluations"), metavar="K",
                        help="terrains per evaluation, fitness their mean v_x "
                        "(default 1: the paper)")
    parser.add_argument("--validate-every", type=whole_int("validate_every"), metavar="N",
                        help=f"log the best's mean v_x on the {VALIDATION_COUNT} validation "
                        "terrains every N generations and at the last (default 50; 0: never)")
    parser.add_argument("--omega", type=finite_float("omega"),
                        help=f"modularity bias (default {OperatorConfig().omega:g}: none)")
    parser.add_argument("--modules",
                        help="partition for omega: paper, worm-halves, biped-legs, a grid "
                        "or a partition.json (default paper)")
    parser.add_argument("--distance-bias", type=finite_float("distance_bias"), metavar="K",
                        help="beyond the paper: add_edge weighs a pair of nodes d voxels apart "
                        "by exp(-K d), on top of omega (default 0: no bias)")
    parser.add_argument("--delay-per-voxel", type=finite_float("delay_per_voxel"), metavar="S",
                        help="beyond the paper: an edge d voxels long is delayed by "
                        f"max(1, ceil(S d)) control steps, at most {MAX_EDGE_DELAY} (default 0: "
                        "one step per edge, the paper's); the genomes carry it")
    parser.add_argument("--weights-only", action="store_true", default=None,
                        help="the ablation: only weight mutation (p_mutate_edge 1, others 0)")
    parser.add_argument("--reevaluate-parents", action=argparse.BooleanOptionalAction,
                        default=None,
                        help="evaluate parents again every generation, on new terrains (the "
                        "default, as the authors' code; --no-reevaluate-parents: Algorithm 1 "
                        "as printed, each parent keeps its one evaluation)")
    parser.add_argument("--checkpoint-every", type=whole_int("checkpoint_every"), metavar="N",
                        help="generations between checkpoints (default: the --config file's, "
                        f"else {RunConfig.checkpoint_every})")
    parser.add_argument("--resume", action="store_true",
                        help="continue from the last checkpoint (a run killed before its first "
                        "one starts again: the same run)")
    parser.add_argument("--force", action="store_true", help="overwrite an existing run")
    parser.add_argument("--force-physics", action="store_true",
                        help="with --resume: resume a run that ran under another physics "
                        "version than this somite's (refused without it); its physics.json "
                        "records that")
    add_options(parser, "backend", "quiet", "yes")


_OPTIONS = ("preset", "shape", "sensors", "generations", "population", "seed", "terrain",
            "duration", "evaluations", "validate_every", "omega", "modules", "weights_only",
            "reevaluate_parents", "checkpoint_every", "distance_bias", "delay_per_voxel")


def run(args: argparse.Namespace) -> int:
    config = configuration(args)
    check_run_work(config, config.body().shape.n_voxels, args.yes)
    backend = check_backend(args.backend)
    # Locked before the progress bar starts, so that a refusal is the only line printed.
    with RunDirectory(args.out).locked() as run_dir:
        with progress_bar(config.generations, args.quiet, backend) as report:
            ea = evolve(config, run_dir, resume=args.resume, force=args.force, progress=report,
                        backend=backend, force_physics=args.force_physics)
    summarise(ea, run_dir, args.quiet)
    warn_whole_episode(args.prog, config.setup.sim)  # last: a caveat on the result
    return 0


def configuration(args: argparse.Namespace, defaults: dict | None = None, **fixed) -> RunConfig:
    """The run's configuration from TOML and options, or the saved one on ``--resume``;
    ``defaults`` (e.g. the settings of the genome a re-optimisation starts from) come before
    the TOML file and the options."""
    cli = {k: getattr(args, k) for k in _OPTIONS if getattr(args, k, None) is not None}
    cli.update(fixed)
    check_output_folder(args.out)  # a bad --out (too long, a file) before it is looked into
    run_dir = RunDirectory(args.out)
    if args.resume and args.force:
        raise bad("resume", True, "--resume and --force exclude each other")
    if args.force_physics and not args.resume:
        raise bad("force_physics", True, "only with --resume (a new run runs under this "
                  "somite's physics)")
    # A run killed before it wrote config.json left an empty directory: resuming it is
    # starting it.
    unborn = run_dir.path.is_dir() and not run_dir.has_run()
    if args.resume and unborn and not (cli or args.config):
        # Starting it with the defaults would be another run than the one that was asked.
        raise bad("resume", str(run_dir.path),
                  "the run was killed before it saved config.json, so its options are "
                  "unknown: start it again with them (the same command without --resume)")
    if args.resume and not unborn:
        config = run_dir.saved_config()
        saved = config.to_dict()
        changed = {k: v for k, v in cli.items() if k != "generations" and saved.get(k) != v}
        if args.config or changed:
            raise bad("resume", sorted(changed) or args.config,
                      "a resumed run keeps its configuration (only --generations may change)")
        if {**saved, **cli} != saved:  # --generations N: only then is it resolved again
            config = resolve({**saved, **cli})
    else:
        options = load_toml(args.config) if args.config else {}
        config = resolve({**(defaults or {}), **options, **cli})
    return config


def summarise(ea: GraphEA, run_dir: RunDirectory, quiet: bool) -> None:
    if quiet:
        return
    print(f"best v_x {ea.best_fitness:.3f} m/s (training) after {ea.generation} generations "
          f"-> {run_dir.file('best.json')}")
    validated = [r for r in ea.log if r["validation_velocity"] is not None]
    if validated:
        print(f"its mean v_x on the validation terrains: {validated[-1]['validation_velocity']:.3f}"
              f" m/s (generation {validated[-1]['generation']})")


class progress_bar:
    """Generations as they go (generation, best v_x, |G|, time elapsed and left), on a terminal
    or not (:class:`~somite.commands._progress.Waiting`), or nothing when quiet. Before the
    first generation is done it says whether it waits for the kernels to compile."""

    def __init__(self, generations: int, quiet: bool, backend: str = "cpu") -> None:
        self.generations = generations
        self.quiet = quiet
        self.backend = backend
        self.wait = None

    def __enter__(self):
        if self.quiet:
            return None
        first = "evolving"
        if will_compile(self.backend):
            sys.stderr.write(COMPILING + "...\n")
            sys.stderr.flush()
            first = "compiling the kernels first"
        self.wait = Waiting(first, total=self.generations, unit="generations", eta=True,
                            transient=False)
        self.wait.__enter__()
        return self.update

    def update(self, ea: GraphEA, row: dict) -> None:
        best = row["best_velocity"]
        shown = "nan" if math.isnan(best) else f"{best:.3f}"
        self.wait.update(text=f"best v_x {shown} m/s, |G| {row['best_size']}",
                         done=ea.generation)
        if row.get("non_finite_episodes"):
            # Printed above the bar; log.csv keeps the count (non_finite_episodes) too.
            self.wait.say(f"warning: generation {ea.generation}: {row['non_finite_episodes']} "
                          f"episodes: {NON_FINITE}")

    def __exit__(self, *exc) -> None:
        if self.wait is not None:
            self.wait.__exit__(*exc)
