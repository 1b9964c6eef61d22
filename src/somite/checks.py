"""The checks of the public Python API's arguments, one function a kind of value (numbers,
text, lists, seeds); :mod:`somite.tasks.arguments` adds somite's own types (a body, a genome,
a terrain, a simulation config) on top.

Every public entry point (:class:`~somite.tasks.stepper.Episode`, :func:`somite.simulate`,
:func:`~somite.tasks.locomotion.simulate_batch`, :func:`somite.evaluate_genomes`,
:class:`~somite.tasks.task.Locomotion`, :class:`~somite.evolution.ea.GraphEA`,
:class:`~somite.sim.config.SimConfig`, :meth:`~somite.sim.body.Body.build`) checks what it is
given here, before anything is built or simulated, with the command line's field names and
bounds (:mod:`somite.limits`): a wrong value is one :class:`~somite.errors.SomiteError` (a
:class:`ValueError`), a wrong type one :class:`~somite.errors.SomiteTypeError` (also a
:class:`TypeError`), each naming the argument and the value. Nothing is converted silently: a
string is not a number, a float not a count, a bool neither.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np

from .errors import SomiteError, bad, bad_type


def is_integer(value) -> bool:
    """An integer (Python's or NumPy's), not a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def is_real(value) -> bool:
    """A real number (int, float, NumPy's), not a bool, not complex."""
    return (isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
            or is_integer(value))


def integer(field: str, value, low: int | None = None, high: int | None = None) -> int:
    """``value`` as an int in [``low``, ``high``] (either end open when None)."""
    if not is_integer(value):
        raise bad_type(field, value, "an integer")
    value = int(value)
    if low is not None and value < low:
        raise bad(field, value, f"must be an integer >= {low}")
    if high is not None and value > high:
        raise bad(field, value, f"must be at most {high:,}")
    return value


def real(field: str, value, low: float | None = None, high: float | None = None, *,
         above: bool = False) -> float:
    """``value`` as a finite float in [``low``, ``high``] (``above``: in (``low``, ``high``])."""
    if not is_real(value):
        raise bad_type(field, value, "a real number")
    try:
        number = float(value)
    except OverflowError:  # an int past float's range
        raise bad(field, value, "must be a finite number") from None
    if not math.isfinite(number):
        raise bad(field, value, "must be a finite number")
    if low is not None and (number <= low if above else number < low):
        raise bad(field, value, f"must be {'above' if above else 'at least'} {low:g}")
    if high is not None and number > high:
        raise bad(field, value, f"must be at most {high:g}")
    return number


def text(field: str, value, choices: Sequence[str] | None = None) -> str:
    """``value`` as a string, one of ``choices`` when given."""
    if not isinstance(value, str):
        raise bad_type(field, value, "a string")
    if choices is not None and value not in choices:
        raise bad(field, value, f"use one of {list(choices)}")
    return value


def flag(field: str, value) -> bool:
    """``value`` as a bool (True or False, NumPy's too; not 0, 1 or a string)."""
    if not isinstance(value, (bool, np.bool_)):
        raise bad_type(field, value, "True or False")
    return bool(value)


def instance(field: str, value, kind: type | tuple[type, ...], expected: str):
    """``value`` itself, if it is a ``kind``."""
    if not isinstance(value, kind):
        raise bad_type(field, value, expected)
    return value


def items(field: str, value, most: int, *, least: int = 0, expected: str = "a list") -> list:
    """``value`` (a list, tuple, range or 1-D array: not a string, a dict or a set, whose
    order or items would be a guess) as a list of ``least`` to ``most`` items."""
    if isinstance(value, np.ndarray):
        if value.ndim != 1:
            raise bad(field, f"an array of shape {value.shape}", "expected one dimension")
    elif isinstance(value, (str, bytes, bytearray)) or not isinstance(value, Sequence):
        raise bad_type(field, value, expected)
    if len(value) < least:
        raise bad(field, f"{len(value)} items", f"needs {least} at least")
    if len(value) > most:
        raise bad(field, f"{len(value)} items", f"must have at most {most:,} (somite.limits)")
    return list(value)


SEED_END = 2**32
"""A seed (``seed=``) is in [0, 2**32), as the command line's ``--seed``."""
NOISE_SEED_END = 2**64
"""A robot's sensor-noise seed in a batch (``seeds=``) is in [0, 2**64)."""


def seeds(field: str, value, n: int) -> list[int]:
    """One noise seed for each of ``n`` robots: an integer (the same for all) or a list of
    ``n`` integers, each in [0, 2**64)."""
    if is_integer(value):
        value = [value] * n
    listed = items(field, value, max(n, 1), expected="an integer or a list of integers")
    if len(listed) != n:
        raise bad(field, f"{len(listed)} seeds", f"need one, or one per robot ({n})")
    return [integer(f"{field}[{i}]" if len(listed) > 1 else field, seed, 0,
                    NOISE_SEED_END - 1) for i, seed in enumerate(listed)]


def named(field: str, parse, value):
    """``parse(value)``, its one-line error led by ``field`` when it names another (a parser
    of the command line's says ``terrain=``; the argument may be ``terrains[3]``)."""
    try:
        return parse(value)
    except SomiteError as error:
        if str(error).startswith(f"{field}="):
            raise
        raise type(error)(f"{field}: {error}") from None


__all__ = ["NOISE_SEED_END", "SEED_END", "flag", "instance", "integer", "is_integer", "is_real",
           "items", "named", "real", "seeds", "text"]
