"""The ``evolve`` kind: an experiment that is a grid of runs (shapes x seeds x variants), each
an ``evolve`` task that writes a run directory (``somite evolve``'s files)."""

from __future__ import annotations

import math
from pathlib import Path

from ...analysis.stats import load_run
from ...brain.genome import Genome
from ...errors import SomiteError, bad
from ...experiments.history import read_history
from ...experiments.logfile import last_validation
from ...sim.body import Shape
from ...sim.config import CONTROL_HZ
from ...tasks.validation import VALIDATION_COUNT
from ..fields import CAMPAIGN_DECIDES, check_name, run_table, typed
from ..layout import at
from .common import RUN_EXTRAS, Needs, log_tail, make_task, number, representation, run_config
from .common import run_options as resolved

FIELDS = frozenset({"shapes", "seeds", "options", "variants"})
OUTPUTS = frozenset({"config.json", "log.csv", "bests.jsonl", "best.json", "checkpoint.json",
                     "manifest.json"})
"""The files of a finished run (a re-optimisation adds its ``transfer.csv``)."""


def parse(table: dict, where: str, earlier: dict, base: Path) -> dict:
    """An evolve experiment's settings: shapes, seeds, options and variants, checked."""
    shapes = typed(table, "shapes", list, None, where)
    if not shapes or not all(isinstance(s, str) and s for s in shapes):
        raise bad(where + "shapes", shapes, "a non-empty list of shapes (biped, worm, ...)")
    if len(set(shapes)) != len(shapes):
        raise bad(where + "shapes", shapes, "a shape is listed twice")
    for shape in shapes:
        if shape != shape.strip():
            raise bad(where + "shapes", shape, "a shape without spaces around it")
        try:
            Shape.parse(shape)
        except SomiteError as error:
            raise SomiteError(f"{where}{error}") from None
    seeds = table.get("seeds")
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        if not 1 <= seeds <= 10_000:
            raise bad(where + "seeds", seeds, "a count from 1 to 10000, or a list of seeds")
        seeds = list(range(seeds))
    if not isinstance(seeds, list) or not seeds or not all(
        isinstance(s, int) and not isinstance(s, bool) and 0 <= s < 2**32 for s in seeds
    ):
        raise bad(where + "seeds", seeds, "a count, or a non-empty list of seeds in [0, 2**32)")
    if len(set(seeds)) != len(seeds):
        raise bad(where + "seeds", seeds, "a seed is listed twice")
    variants = typed(table, "variants", dict, {}, where)
    for variant, options in variants.items():
        check_name(where + "variants", variant)
        if not isinstance(options, dict):
            raise bad(where + "variants." + variant, options, "expected a table of run options")
    return {"shapes": tuple(shapes), "seeds": tuple(seeds),
            "options": run_table(typed(table, "options", dict, {}, where), where + "options.",
                                 CAMPAIGN_DECIDES, base),
            "variants": {k: run_table(v, f"{where}variants.{k}.", CAMPAIGN_DECIDES, base)
                         for k, v in variants.items()}}


def expand(campaign, exp, grids: dict) -> tuple[list[dict], dict]:
    """The runs of the grid, and the grid itself (variant -> shape -> [(seed, task)]), which
    the experiments after it read their donors from."""
    tasks: list[dict] = []
    groups: dict[str, dict[str, list]] = {}
    settings = exp.settings
    for variant, extra in (settings["variants"] or {"": {}}).items():
        grid = groups.setdefault(variant, {})
        for shape in settings["shapes"]:
            for seed in settings["seeds"]:
                where = f"experiments.{exp.name}" + (f".variants.{variant}" if variant else "")
                options = resolved(where, {**campaign.defaults, **settings["options"], **extra,
                                           "shape": shape, "seed": seed})
                prefix = f"{variant}-" if variant else ""
                task = make_task(exp.name, f"{prefix}{shape}-s{seed}", "evolve", [], options)
                tasks.append(task)
                grid.setdefault(shape, []).append((seed, task))
    return tasks, groups


def run(root: Path, out: Path, options: dict) -> int:
    from ...experiments.runner import evolve

    ea = evolve(run_config(options), out, resume=True)
    return run_steps(options, ea.generation)


def check_run(where: str, task: dict, needs: Needs):
    """A run's options (an evolve or re-optimisation task): they resolve, and make the
    ``representation`` they say; returns the :class:`RunConfig`."""
    options = task["options"]
    try:
        config = run_config(options)
    except SomiteError as error:
        raise SomiteError(at(f"{where}.{error}")) from None
    made = representation(config)
    if options.get("representation", made) != made:
        raise bad(at(f"{where}.representation"), options["representation"],
                  f"the options make a {made!r} run")
    return config


def check(where: str, task: dict, needs: Needs) -> None:
    config = check_run(where, task, needs)
    options = task["options"]
    for key in ("donors", "validation"):
        if key in options:
            raise bad(at(f"{where}.{key}"), options[key],
                      "only a re-optimisation has donors and validation")
    if config.start:
        raise bad(at(f"{where}.start"), config.start, "an evolve run starts from scratch")


def read(folder: Path, options: dict) -> dict:
    """What the report reads of a finished run: its log and config, its best genome, and the
    episode settings it trained with (for the re-run on the validation terrains)."""
    found = load_run(folder)
    # The log and the bests checked line by line, as a resume checks them: a finished run
    # whose bests.jsonl was deleted or cut is named among the unreadable tasks.
    read_history(folder)
    sim = run_config(found.config).setup.sim
    return {"runs": found, "bests": Genome.load(folder / "best.json"), "sims": sim}


TAIL_BYTES = 1 << 16
"""How much of a log's end :func:`progress` reads: some 500 rows, more than a run's validation
interval (every 50 generations in the built-ins)."""


def progress(folder: Path, options: dict, done: bool) -> dict:
    """How far the run has got: its last log row's generation and best v_x, and the last
    validation v_x among the log's last rows (a run validates every few generations)."""
    rows = log_tail(folder / "log.csv", TAIL_BYTES)
    if not rows:
        return {}
    found = {"generation": int(rows[-1]["generation"]),
             "best": number(rows[-1]["best_velocity"]),
             "validation": last_validation(rows)}
    pace = seconds_per_generation(rows[-PACE_GENERATIONS - 1:])
    if pace is not None:
        found["seconds_per_generation"] = pace
    return found


PACE_GENERATIONS = 100
"""How many of a log's last generations :func:`progress` times the run's pace over."""


def seconds_per_generation(rows: list[dict]) -> float | None:
    """The run's pace over ``rows`` (log rows in order), from their ``elapsed_seconds``, which
    count the run's own computing only (a resume goes on from its checkpoint's count, not from
    the wall clock); None with fewer than two timed rows."""
    timed = [(int(row["generation"]), number(row.get("elapsed_seconds"))) for row in rows]
    timed = [(g, e) for g, e in timed if e is not None and math.isfinite(e)]
    if len(timed) < 2 or timed[-1][0] <= timed[0][0] or timed[-1][1] <= timed[0][1]:
        return None
    return (timed[-1][1] - timed[0][1]) / (timed[-1][0] - timed[0][0])


def run_steps(options: dict, generations: int | None = None) -> int:
    """Robot-control-steps of an evolve or re-optimisation run with ``options`` (to
    ``generations``, default all): its training episodes, validations and, for a
    re-optimisation, the transfer curve's upper bound (every best distinct) and the donors."""
    generations = options["generations"] if generations is None else generations
    steps = int(round(options["duration"] * CONTROL_HZ))
    population = options["population"]
    per_generation = population * (2 if options["reevaluate_parents"] else 1)
    training = (population + generations * per_generation) * options["evaluations"]
    every = options["validate_every"]
    validations = 0
    if every:
        validations = len({g for g in range(0, generations + 1, every)} | {generations})
    episodes = training + validations * VALIDATION_COUNT
    if "donors" in options:
        episodes += (generations + 1 + len(options["donors"])) * options["validation"]
    return episodes * steps


def estimate(options: dict) -> int:
    """Robot-control-steps of the whole run."""
    return run_steps(options)


__all__ = ["FIELDS", "OUTPUTS", "PACE_GENERATIONS", "RUN_EXTRAS", "check", "check_run",
           "estimate", "expand", "parse", "progress", "read", "run", "run_steps",
           "seconds_per_generation"]
