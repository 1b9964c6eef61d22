"""Argument types and output helpers shared by the sub-commands."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys

from .._io import json_safe
from ..errors import bad
from ..tasks.backends import BACKENDS, backend_help
from ..tasks.validation import VALIDATION_COUNT

MAX_NUMBER_CHARS = 30
"""The most characters of a number on the command line; a longer one is refused unread (int()
of over 4300 digits is a ValueError, float() of 400 is infinity)."""


def _too_long(text: str) -> bool:
    return len(text.strip()) > MAX_NUMBER_CHARS


# ASCII digits only: int() and float() also read "4_0", "+4", " 4" and other scripts' digits,
# which a terrain name refuses; one spelling of a number everywhere.
_INTEGER = re.compile(r"-?[0-9]+")
_FLOAT = re.compile(r"-?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?|-?(inf|nan)", re.IGNORECASE)


def finite_float(field: str):
    """An argparse type: a finite float, or a one-line error naming ``field``."""

    def parse(text: str) -> float:
        if _too_long(text):
            raise argparse.ArgumentTypeError(str(bad(
                field, text, f"must be a number of at most {MAX_NUMBER_CHARS} characters")))
        try:
            if not _FLOAT.fullmatch(text):
                raise ValueError(text)
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(str(bad(field, text, "must be a number"))) from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(str(bad(field, text, "must be a finite number")))
        return value

    parse.__name__ = field
    return parse


def whole_int(field: str):
    """An argparse type: an integer (its range is checked where it is used), or a one-line
    error naming ``field``."""

    def parse(text: str) -> int:
        if _too_long(text):
            raise argparse.ArgumentTypeError(str(bad(
                field, text, f"must be an integer of at most {MAX_NUMBER_CHARS} characters")))
        try:
            if not _INTEGER.fullmatch(text):
                raise ValueError(text)
            return int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(str(bad(field, text, "must be an integer"))
                                             ) from None

    parse.__name__ = field
    return parse


def print_json(data) -> None:
    """``data`` as strict JSON on stdout: NaN and infinities are ``null`` (the README's promise;
    ``NaN`` is not JSON)."""
    json.dump(json_safe(data), sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


def warn(prog: str, message: str) -> None:
    """A warning: one line on stderr, beside a result that is still given."""
    sys.stderr.write(f"{prog}: warning: {message}\n")


NON_FINITE = ("a controller output or the physics state was NaN or infinite (actuation is "
              "clamped to [-1, 1], NaN as -1; the physics stops the episode)")
"""What a non-zero ``non_finite`` means, for the warnings of the commands that report it."""


def add_genome(parser: argparse.ArgumentParser, name: str = "genome", role: str = "") -> None:
    """A positional genome argument, read by :func:`load_genome`; ``role`` says whose it is."""
    what = f"{role}: " if role else ""
    parser.add_argument(name, help=f"{what}genome JSON, or a run directory (its best.json)")


def load_genome(path: str):
    """A genome from a genome JSON file, or from a run directory's ``best.json``."""
    from pathlib import Path

    from ..brain.genome import Genome

    target = Path(path)
    try:
        folder, there = target.is_dir(), target.exists()
    except OSError as error:  # a name too long for the file system, ...
        raise bad("genome", path, f"cannot read the file ({error.strerror})") from None
    if folder:
        if not (target / "best.json").is_file():
            raise bad("genome", path, "a run directory without best.json")
        target = target / "best.json"
    elif not there:
        raise bad("genome", path, "no such file or run directory")
    return Genome.load(target)


def seed_int(text: str) -> int:
    """An argparse type: a seed in [0, 2**32), or a one-line error naming ``seed``."""
    if _too_long(text):
        raise argparse.ArgumentTypeError(str(bad("seed", text, "must be in [0, 2**32)")))
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(str(bad("seed", text, "must be an integer"))) from None
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(str(bad("seed", text, "must be in [0, 2**32)")))
    return value


DEFAULTS = {
    "duration": 30.0,
    "seed": 0,
    "preset": "paper",
    "shape": "worm",
    "sensors": "paper",
    "validation": VALIDATION_COUNT,
}
"""The one default of each shared option; the library's defaults are the same values
(``tests/test_cli.py`` checks that ``somite evolve`` records them)."""

_SHARED = {
    "duration": ({"type": finite_float("duration"), "metavar": "S"}, "episode length [s]"),
    "seed": ({"type": seed_int}, "random seed"),
    "preset": ({}, "paper or original-code (docs/decisions.md, Presets)"),
    "shape": ({}, "biped, worm, WxH or rows like 1111/1001"),
    "sensors": ({}, "sensor preset: paper, none, area or all"),
    "validation": ({"type": whole_int("validation"), "metavar": "N"},
                   "how many fixed validation terrains"),
    "backend": ({"default": "cpu", "metavar": "{" + ",".join(BACKENDS) + "}"}, backend_help()),
    "json": ({"action": "store_true"}, "print JSON"),
    "yes": ({"action": "store_true"}, "start work estimated at more than 12 h on 2 cores "
            "(refused without it)"),
    "quiet": ({"action": "store_true"}, "print nothing while running"),
}


def add_options(parser: argparse.ArgumentParser, *names: str, layered: str = "",
                notes: dict[str, str] | None = None) -> None:
    """Declare the shared options ``names`` (``--duration``, ``--seed``, ...) on ``parser``.

    ``genome`` is the positional genome argument (:func:`add_genome`). Each option takes its
    one default from :data:`DEFAULTS`. With ``layered`` (e.g. "the run's"), an
    option not given is None and the command takes ``layered``'s value first, the default only
    after it (:func:`option`). ``notes`` adds a command's remark to an option's help.
    """
    for name in names:
        if name == "genome":
            add_genome(parser)
            continue
        kwargs, text = _SHARED[name]
        kwargs = dict(kwargs)
        if name in DEFAULTS:
            kwargs["default"] = None if layered else DEFAULTS[name]
            shown = f"{DEFAULTS[name]:g}" if name == "duration" else DEFAULTS[name]
            text += f" (default: {layered}, else {shown})" if layered else f" (default {shown})"
        if notes and name in notes:
            text += f"; {notes[name]}"
        parser.add_argument(f"--{name}", help=text, **kwargs)


def option(args: argparse.Namespace, name: str, saved: dict | None = None):
    """A layered option's value: given, else ``saved[name]`` (a run's config), else its default."""
    value = getattr(args, name, None)
    if value is None:
        value = (saved or {}).get(name, DEFAULTS[name])
    return value


def add_simulation_options(parser: argparse.ArgumentParser, layered: str = "") -> None:
    """``--duration``, ``--preset`` and ``--seed``: how a command simulates."""
    add_options(parser, "duration", "preset", layered=layered)
    add_options(parser, "seed", notes={"seed": "it draws the sensor noise"})


GENOME_RUN = "the genome's run's"
"""The ``layered`` text of options that a genome's run (or reassembly) fills
(:mod:`somite.experiments.origin`)."""


def simulation_config(args: argparse.Namespace, origin=None):
    """The :class:`~somite.sim.config.SimConfig` of :func:`add_simulation_options`' options.

    ``origin`` (an :class:`~somite.experiments.origin.Origin`) fills the options not given,
    and its ``transient``.
    """
    from ..sim.config import preset

    saved = origin.options() if origin is not None else {}
    options = {"duration": float(option(args, "duration", saved))}
    if "transient" in saved:
        options["transient"] = saved["transient"]
    return preset(option(args, "preset", saved), **options)


def settings_line(args: argparse.Namespace, config, origin=None, terrain: str = "") -> str:
    """One line saying which settings a command simulates with, and where they came from."""
    saved = origin.options() if origin is not None else {}
    where = f"{terrain}, " if terrain else ""
    start, end = config.measured_interval
    text = (f"settings: {where}{config.duration:g} s (v_x over [{start:g} s, {end:g} s]), "
            f"preset {option(args, 'preset', saved)}, seed {args.seed}")
    if origin is not None and origin.source:
        text += f"; from {origin.source} where not given"
    return text


def warn_whole_episode(prog: str, config) -> None:
    """Warn when ``config`` (a SimConfig) measures v_x over the whole episode, start-up
    included, because its duration is not longer than its transient."""
    from ..sim.config import whole_episode_warning

    message = whole_episode_warning(config)
    if message:
        warn(prog, message)


def check_run_work(config, voxels: int, yes: bool, what: str = "this run") -> None:
    """Refuse a run (a :class:`~somite.experiments.config.RunConfig`) that would not finish
    in :data:`~somite.budget.MAX_HOURS` without ``yes``, or whose batches would not fit."""
    from ..budget import check_batch, check_steps
    from ..campaigns.kinds.evolve import run_steps

    options = config.to_dict()
    check_steps(what, run_steps(options), voxels, yes)
    per_batch = options["population"] * (2 if options["reevaluate_parents"] else 1)
    check_batch(per_batch * options["evaluations"], voxels)


def check_episodes(episodes: int, config, body, yes: bool, what: str) -> None:
    """Refuse ``episodes`` episodes of ``body`` under ``config`` (a SimConfig), run as one
    batch, that would not finish in :data:`~somite.budget.MAX_HOURS` without ``yes`` or whose
    batch would not fit in memory."""
    from ..budget import check_batch, check_steps

    voxels = body.shape.n_voxels
    check_steps(what, float(episodes) * config.n_steps, voxels, yes)
    check_batch(episodes, voxels)
