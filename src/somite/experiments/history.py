"""A run's history read strictly, for ``--resume``: all of it is consistent, or nothing goes on.

``--resume`` continues a run from its checkpoint and rewrites the rows after it, which the run
itself wrote and will write again identically. It must not drop anything else: a row it cannot
read is not the end of the history but a damaged file, and is refused with one line naming the
file, the line and what is wrong, before any file is touched. The one thing a kill leaves that
is not an error is a torn last line (an append cut short, without its newline), which is the
run's own and is rewritten.

A line of ``bests.jsonl`` may be *thinned* (``somite campaign pack`` keeps a best every few
generations): ``{"generation":G,"thinned":"DIGEST"}``, the short digest of the line it stands
for. It counts as that line everywhere the history is checked or sealed, so that a run
unpacked from a pack resumes, and seals its checkpoints, exactly as the run it was packed from;
only the genome of that generation is gone.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from .._io import read_text
from ..errors import SomiteError, bad
from ..limits import MAX_INPUT_BYTES
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
    if len(bests) > len(rows):
        raise bad("log", f"{folder / 'log.csv'}, line {len(rows) + 2}", f"missing: the log "
                  f"ends after {len(rows)} generations where bests.jsonl holds {len(bests)}")
    if len(bests) < len(rows) - 1:
        raise bad("bests", f"{folder / 'bests.jsonl'}, line {len(bests) + 1}", f"missing: "
                  f"bests.jsonl ends after {len(bests)} generations where log.csv holds "
                  f"{len(rows)}")
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


@dataclass
class Digests:
    """The short digest (:func:`line_digest`) of every complete line of a run's ``log.csv``
    (its header left out) and ``bests.jsonl``, kept as the run writes them: the digests
    :func:`seal_checkpoint` would otherwise read both files again for, at every checkpoint
    (tens of MB at the paper's budget)."""

    log: list[str] = field(default_factory=list)
    bests: list[str] = field(default_factory=list)

    def wrote(self, name: str, text: str) -> None:
        """``text`` (whole lines, each ending in a newline) was appended to the file of
        ``name`` (``log`` or ``bests``): its lines are split and digested as a reading of
        the file would split and digest them."""
        getattr(self, name).extend(line_digest(name, line) for line in text.split("\n")[:-1])

    def up_to(self, generation: int) -> dict[str, list[str]]:
        """The digests of generations 0 to ``generation``, as a checkpoint's ``history``."""
        return {name: getattr(self, name)[: generation + 1] for name in HISTORY_FILES}


def seal_checkpoint(data: dict, folder: Path, digests: Digests | None = None) -> dict:
    """``data`` (a checkpoint at ``data["generation"]``) with a short digest of each line of
    the run's history up to it (``history``: the log rows and bests lines of generations 0 to
    it, as in ``folder`` now, or as ``digests`` kept them while the run wrote them) and a
    checksum of the whole (``sha256``): a checkpoint, log row or best changed afterwards, even
    in a value that still parses, is then found by :func:`check_checksum` and
    :func:`check_history` (naming the line) instead of resumed into another run.

    The wall-clock time (:data:`UNSEALED`) is left out of both, so that a run's checkpoints
    stay the same from machine to machine, as its other files do; it is only checked to be
    a time."""
    generation = data["generation"]
    history = (_line_digests(folder, generation) if digests is None
               else digests.up_to(generation))
    sealed = {**data, "history": history}
    sealed["sha256"] = _checksum(sealed)
    return sealed


def check_checksum(data: dict, path: Path) -> None:
    """Refuse the checkpoint ``data`` (read from ``path``) whose checksum
    (:func:`seal_checkpoint`) does not match. A checkpoint without one is of a somite before
    the seal and is read as before."""
    if "sha256" not in data and "history" not in data:
        return
    if data.get("sha256") != _checksum(data):
        raise bad("checkpoint", str(path), "damaged checkpoint (its checksum does not match "
                  "its contents)")
    elapsed = data.get(UNSEALED)
    if isinstance(elapsed, bool) or not isinstance(elapsed, (int, float)) or not (
        0 <= elapsed < math.inf
    ):
        raise bad("checkpoint.elapsed_seconds", elapsed, "damaged checkpoint (not a time)")


def check_history(data: dict, path: Path) -> None:
    """Refuse the checkpoint ``data`` (read from ``path``, its checksum and generation
    checked) when the run's log or bests up to its generation are not what they were when it
    was written, naming the first line that changed."""
    if "history" not in data:
        return
    generation = data["generation"]
    found = _line_digests(path.parent, generation)
    for name, first in (("log", 2), ("bests", 1)):
        file = path.parent / HISTORY_FILES[name]
        written, now = data["history"][name], found[name]
        for index, (old, new) in enumerate(zip(written, now)):
            if old != new:
                raise bad(name, f"{file}, line {index + first}", "is not what the run wrote "
                          f"there (changed after the checkpoint of generation {generation})")
        if len(now) < len(written):
            raise bad(name, f"{file}, line {len(now) + first}", f"missing: the checkpoint of "
                      f"generation {generation} was written after {len(written)} generations")


HISTORY_FILES = {"log": "log.csv", "bests": "bests.jsonl"}
"""The files of a run's history, by the name its errors and digests give them."""


UNSEALED = "elapsed_seconds"
"""The one value of a checkpoint, and the one cell of a log row, that no seal covers: the
wall-clock time, which is not the same from machine to machine."""


def _checksum(data: dict) -> str:
    """sha256 of ``data`` but its own checksum and the wall-clock time."""
    sealed = {k: v for k, v in data.items() if k not in ("sha256", UNSEALED)}
    text = json.dumps(sealed, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _sealed_part(name: str, line: str) -> str:
    """A log line without its elapsed time; a bests line whole."""
    if name != "log":
        return line
    cells = line.split(",")
    at = LOG_COLUMNS.index(UNSEALED)
    return ",".join(cells[:at] + cells[at + 1:])


def _line_digests(folder: Path, generation: int) -> dict[str, list[str]]:
    """A short hash of each complete line of generations 0 to ``generation`` of ``log.csv``
    and ``bests.jsonl``, as written (a resume's cut-back writes them again byte for byte).
    Eight hex digits a line: a few kB for thousands of generations."""
    return {name: [line_digest(name, line) for _, line in
                   _complete_lines(folder / file, name, name == "log")[: generation + 1]]
            for name, file in HISTORY_FILES.items()}


def _complete_lines(path: Path, field: str, header: bool) -> list[tuple[int, str]]:
    """(line number, text) of every complete line, the header (checked) left out."""
    try:
        text = read_text(path, field)
    except SomiteError:
        line = _line_not_utf8(path)
        if line is None:
            raise
        raise bad(field, f"{path}, line {line}", "not UTF-8 text") from None
    lines = text.split("\n")
    lines.pop()  # "" after the last newline, or the torn line a kill left
    if header:
        expected = ",".join(LOG_COLUMNS)
        if not lines or lines[0] != expected:
            found = lines[0][:80] if lines else "nothing"
            raise bad(field, f"{path}, line 1", f"header {found!r} is not somite's log header")
        return list(enumerate(lines[1:], 2))
    return list(enumerate(lines, 1))


def _line_not_utf8(path: Path) -> int | None:
    """The number of the first line of the file ``path`` that is not UTF-8, if that is what
    :func:`~somite._io.read_text` refused it for (None otherwise: missing, too big, ...)."""
    try:
        if not path.is_file() or path.stat().st_size > MAX_INPUT_BYTES:
            return None
        data = path.read_bytes()
        data.decode("utf-8")
    except UnicodeDecodeError as error:
        return data.count(b"\n", 0, error.start) + 1
    except OSError:
        return None
    return None


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
    thinned = THINNED.fullmatch(line)
    if thinned:
        return {"generation": int(thinned[1]), "thinned": thinned[2]}
    try:
        entry = json.loads(line)
    except (ValueError, RecursionError) as error:
        raise bad("bests", where, f"not JSON ({str(error)[:60]})") from None
    if not (isinstance(entry, dict) and isinstance(entry.get("genome"), dict)
            and isinstance(entry.get("generation"), int)
            and not isinstance(entry.get("generation"), bool)):
        raise bad("bests", where, "not a best genome of a generation")
    return entry


THINNED = re.compile(r'\{"generation":(0|[1-9][0-9]{0,17}),"thinned":"([0-9a-f]{8})"\}')
"""A thinned line of ``bests.jsonl`` (see the module docstring); written by
:func:`thinned_line` exactly so, which is what a resume's cut-back writes it again as."""


def thinned_line(generation: int, digest: str) -> str:
    """The line that stands for a best of ``generation`` whose line had ``digest``."""
    return json.dumps({"generation": generation, "thinned": digest}, separators=(",", ":"))


def line_digest(name: str, line: str) -> str:
    """The short digest the seal keeps of a line of ``log.csv`` (``name`` ``log``, its
    elapsed time left out) or ``bests.jsonl`` (``bests``; a thinned line gives the digest of
    the line it stands for)."""
    if name == "bests":
        thinned = THINNED.fullmatch(line)
        if thinned:
            return thinned[2]
    return hashlib.sha256(_sealed_part(name, line).encode("utf-8")).hexdigest()[:8]


__all__ = ["HISTORY_FILES", "THINNED", "Digests", "History", "check_checkpoint",
           "check_checksum", "check_history", "line_digest", "read_history", "seal_checkpoint",
           "thinned_line"]
