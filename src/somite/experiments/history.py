"""A run's history read strictly, for ``--resume``: all of it is consistent, or nothing goes on.

``--resume`` continues a run from its checkpoint and rewrites the rows after it, which the run
itself wrote and will write again identically. It must not drop anything else: a row it cannot
read is not the end of the history but a damaged file, and is refused with one line naming the
file, the line and what is wrong, before any file is touched. The one thing a kill leaves that
is not an error is a torn last line (an append cut short, without its newline), which is the
run's own and is rewritten.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

from .._io import read_text
from ..errors import bad
from .logfile import LOG_COLUMNS

_INTEGERS = ("generation", "evaluations", "best_nodes", "best_edges", "best_size", "nan_count")
_FLOATS = ("elapsed_seconds", "best_velocity", "median_velocity", "worst_velocity",
           "median_size")
_OPTIONAL = ("non_finite_episodes", "validation_velocity")
"""Cells that may be empty: counted only by some callers; measured only where due."""


@dataclass(frozen=True)
class History:
    """The complete rows of ``log.csv`` (as dicts of strings) and lines of ``bests.jsonl``
    (parsed), each numbered from generation 0 on."""

    rows: list[dict]
    bests: list[dict]


def read_history(folder: Path) -> History:
    """The run's log and bests, checked line by line (see the module's docstring)."""
    rows = [_row(folder / "log.csv", n, line)
            for n, line in _complete_lines(folder / "log.csv", "log", header=True)]
    bests = [_best(folder / "bests.jsonl", n, line)
             for n, line in _complete_lines(folder / "bests.jsonl", "bests", header=False)]
    for index, row in enumerate(rows):
        if int(row["generation"]) != index:
            raise bad("log", f"{folder / 'log.csv'}, line {index + 2}",
                      f"generation {row['generation']} where {index} belongs (rows missing, "
                      "repeated or out of order)")
    for index, best in enumerate(bests):
        if best["generation"] != index:
            raise bad("bests", f"{folder / 'bests.jsonl'}, line {index + 1}",
                      f"generation {best['generation']} where {index} belongs")
    # A generation's row is appended before its best: a kill between leaves one row more.
    if len(bests) not in (len(rows), len(rows) - 1):
        raise bad("bests", str(folder / "bests.jsonl"),
                  f"{len(bests)} generations where log.csv holds {len(rows)}")
    for earlier, later in zip(rows, rows[1:]):
        if int(later["evaluations"]) < int(earlier["evaluations"]):
            raise bad("log", f"{folder / 'log.csv'}, generation {later['generation']}",
                      f"evaluations fell from {earlier['evaluations']} to "
                      f"{later['evaluations']}")
    return History(rows, bests)


def check_checkpoint(history: History, ea, population: int, path: Path) -> None:
    """The checkpointed EA ``ea`` agrees with the log at its generation: population size,
    evaluations and best fitness (a checkpoint edited, or of another moment of the run, is
    refused)."""
    size = len(ea.population.genomes)
    if size != population:
        raise bad("checkpoint", str(path), f"holds {size} genomes where config.json's "
                  f"population is {population}")
    row = history.rows[ea.generation]
    if ea.evaluations != int(row["evaluations"]):
        raise bad("checkpoint.evaluations", ea.evaluations,
                  f"log.csv says {row['evaluations']} at generation {ea.generation}")
    logged = float(row["best_velocity"])
    best = ea.best_fitness
    if not (best == logged or (math.isnan(best) and math.isnan(logged))):
        raise bad("checkpoint", str(path), f"its best fitness {best!r} is not log.csv's "
                  f"{logged!r} at generation {ea.generation}")


def _complete_lines(path: Path, field: str, header: bool) -> list[tuple[int, str]]:
    """(line number, text) of every complete line, the header (checked) left out."""
    text = read_text(path, field)
    lines = text.split("\n")
    lines.pop()  # "" after the last newline, or the torn line a kill left
    if header:
        expected = ",".join(LOG_COLUMNS)
        if not lines or lines[0] != expected:
            found = lines[0][:80] if lines else "nothing"
            raise bad(field, f"{path}, line 1", f"header {found!r} is not somite's log header")
        return list(enumerate(lines[1:], 2))
    return list(enumerate(lines, 1))


def _row(path: Path, number: int, line: str) -> dict:
    where = f"{path}, line {number}"
    cells = next(csv.reader([line]), [])
    if len(cells) != len(LOG_COLUMNS):
        raise bad("log", where, f"{len(cells)} cells where the header has {len(LOG_COLUMNS)}")
    row = dict(zip(LOG_COLUMNS, cells))
    for name in (*_INTEGERS, *_FLOATS, *_OPTIONAL):
        value = row[name]
        if value == "" and name in _OPTIONAL:
            continue
        try:
            number_value = int(value) if name in _INTEGERS else float(value)
        except ValueError:
            kind = "a whole number" if name in _INTEGERS else "a number"
            raise bad("log", where, f"{name}={value[:40]!r} is not {kind}") from None
        if name in _INTEGERS and number_value < 0:
            raise bad("log", where, f"{name}={value!r} is negative")
    return row


def _best(path: Path, number: int, line: str) -> dict:
    where = f"{path}, line {number}"
    try:
        entry = json.loads(line)
    except (ValueError, RecursionError) as error:
        raise bad("bests", where, f"not JSON ({str(error)[:60]})") from None
    if not (isinstance(entry, dict) and isinstance(entry.get("genome"), dict)
            and isinstance(entry.get("generation"), int)
            and not isinstance(entry.get("generation"), bool)):
        raise bad("bests", where, "not a best genome of a generation")
    return entry


__all__ = ["History", "check_checkpoint", "read_history"]
