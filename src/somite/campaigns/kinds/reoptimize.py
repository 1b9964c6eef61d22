"""The ``reoptimize`` kind: a reassembly re-evolved (``somite reoptimize``), with the transfer
curve rho per generation. Its tasks are made by a reassemble experiment (its ``reoptimize``
table), never by an experiment of its own."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from ..._io import read_text
from ...analysis.stats import number
from ...brain.genome import Genome
from ...errors import bad
from ...tasks.validation import check_count
from .common import Needs, run_config
from .evolve import OUTPUTS as RUN_OUTPUTS
from .evolve import check_run, progress, run_steps
from .evolve import read as read_run

OUTPUTS = RUN_OUTPUTS | {"transfer.csv"}


def run(root: Path, out: Path, options: dict) -> int:
    from ...experiments.reoptimize import reoptimize

    start = Genome.load(root / options["start"] / "reassembled.json")
    donors = [Genome.load(root / d / "best.json") for d in options["donors"]]
    ea, _, _ = reoptimize(run_config(options), out, start, donors, options["validation"],
                          resume=True)
    return run_steps(options, ea.generation)


def check(where: str, task: dict, needs: Needs) -> None:
    config = check_run(where, task, needs)
    needs.needed(f"{where}.start", task, config.start, "reassembled.json")
    needs.donors(f"{where}.donors", task, None)
    check_count(task["options"].get("validation"))


def read(folder: Path, options: dict) -> dict:
    """The run (as an evolve task's) and ``transfer.csv``'s rows."""
    rows = read_transfer(folder)
    return {**read_run(folder, options), "transfer": rows}


def read_transfer(folder: Path) -> list[dict]:
    """``transfer.csv`` as rows of floats (generation, training and validation v_x, rho)."""
    path = folder / "transfer.csv"
    text = read_text(path, "transfer")
    reader = csv.DictReader(text.splitlines())
    if "rho" not in (reader.fieldnames or ()) or "generation" not in reader.fieldnames:
        raise bad("transfer", str(path), "lacks the columns generation and rho")
    rows = []
    for line, row in enumerate(reader, start=2):
        if None in row or None in row.values():
            raise bad("transfer", f"{path}, line {line}", "has another number of cells "
                      "than the header")
        rows.append({k: _cell(path, line, k, v) for k, v in row.items()})
    if not rows:
        raise bad("transfer", str(path), "has no rows")
    return rows


def _cell(path: Path, line: int, column: str, text: str) -> float:
    """A cell of ``transfer.csv``: a number, or empty (NaN: not measured); anything else is
    a damaged file, not a NaN."""
    value = number(text)
    if text.strip() and math.isnan(value) and text.strip().lower() != "nan":
        raise bad("transfer", f"{path}, line {line}", f"{column}={text[:40]!r} is not a number")
    return value


def estimate(options: dict) -> int:
    return run_steps(options)


__all__ = ["OUTPUTS", "check", "estimate", "progress", "read", "read_transfer", "run"]
