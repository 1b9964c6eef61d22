"""Argument types and output helpers shared by the sub-commands."""

from __future__ import annotations

import argparse
import json
import math
import sys

from ..errors import bad


def finite_float(field: str):
    """An argparse type: a finite float, or a one-line error naming ``field``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(str(bad(field, text, "must be a number"))) from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(str(bad(field, text, "must be a finite number")))
        return value

    parse.__name__ = field
    return parse


def print_json(data) -> None:
    json.dump(data, sys.stdout, indent=2, allow_nan=True)
    sys.stdout.write("\n")


def load_genome(path: str):
    """A genome from a genome JSON file, or from a run directory's ``best.json``."""
    from pathlib import Path

    from ..brain.genome import Genome

    target = Path(path)
    if target.is_dir():
        if not (target / "best.json").is_file():
            raise bad("genome", path, "a run directory without best.json")
        target = target / "best.json"
    elif not target.exists():
        raise bad("genome", path, "no such file or run directory")
    return Genome.load(target)


def seed_int(text: str) -> int:
    """An argparse type: a seed in [0, 2**32), or a one-line error naming ``seed``."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(str(bad("seed", text, "must be an integer"))) from None
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(str(bad("seed", text, "must be in [0, 2**32)")))
    return value


def add_simulation_options(parser: argparse.ArgumentParser) -> None:
    """``--duration``, ``--preset`` and ``--seed``: how a command simulates."""
    from ..sim.config import PRESETS

    parser.add_argument("--duration", type=finite_float("duration"), default=30.0,
                        help="episode length [s]")
    parser.add_argument("--preset", default="paper", choices=sorted(PRESETS),
                        help="simulation preset")
    parser.add_argument("--seed", type=seed_int, default=0, help="seed of the sensor noise")


def simulation_config(args: argparse.Namespace):
    """The :class:`~somite.sim.config.SimConfig` of :func:`add_simulation_options`' options."""
    from ..sim.config import preset

    return preset(args.preset, duration=args.duration)
