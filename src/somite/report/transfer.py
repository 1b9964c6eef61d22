"""The transfer section: every final best re-run in the paper's simulator (2D-VSR-Sim), its
velocity there over its velocity in somite, per run.

somite does not run Java. ``benchmarks/transfer.py`` does (the driver of
``shared/tools/closed-loop-2dvsrsim/``), once with dyn4j as shipped (``stock``) and once with
its continuous collision detection off (``noccd``, where it misfires against the terrain); its
per-run ratios go into ``transfer.csv`` at the top of the campaign folder (so that a pack
carries them), one row per run and engine::

    task,engine,generation,somite_vx,vsr_vx,ratio
    rq1/biped-s0,stock,3000,4.1,3.2,0.78

``generation`` and the two velocities may be empty; ``ratio`` is vsr_vx / somite_vx. The
report shows the file's rows beside the runs and the median ratio per experiment, shape and
engine; without the file it says how to make it.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from .._io import read_text
from ..errors import bad

TRANSFER_FILE = "transfer.csv"
COLUMNS = ("task", "engine", "generation", "somite_vx", "vsr_vx", "ratio")
ENGINES = ("stock", "noccd")


def _number(text: str, where: str, name: str) -> float | None:
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        raise bad("transfer", where, f"{name}={text[:40]!r} is not a number") from None


def read_transfer(root: Path, tasks: dict[str, tuple[str, str]]) -> dict:
    """``transfer.csv`` of the campaign folder ``root`` (tasks: id -> (experiment, shape) of
    the finished evolve runs): ``present``, its ``rows`` and ``summary`` (median ratio per
    experiment, shape and engine). A malformed file is a one-line error naming its line."""
    path = root / TRANSFER_FILE
    if not path.is_file():
        return {"present": False, "file": TRANSFER_FILE, "rows": [], "summary": []}
    reader = csv.DictReader(io.StringIO(read_text(path, "transfer")))
    missing = [c for c in ("task", "engine", "ratio") if c not in (reader.fieldnames or [])]
    if missing:
        raise bad("transfer", str(path), f"lacks the columns {missing} (of {list(COLUMNS)})")
    rows = []
    for number, row in enumerate(reader, 2):
        where = f"{path}, line {number}"
        if row["engine"] not in ENGINES:
            raise bad("transfer", where, f"engine={row['engine']!r}: use one of {ENGINES}")
        experiment, shape = tasks.get(row["task"], ("", ""))
        rows.append({"task": row["task"], "experiment": experiment, "shape": shape,
                     "known": row["task"] in tasks, "engine": row["engine"],
                     "generation": _number(row.get("generation") or "", where, "generation"),
                     "somite_vx": _number(row.get("somite_vx") or "", where, "somite_vx"),
                     "vsr_vx": _number(row.get("vsr_vx") or "", where, "vsr_vx"),
                     "ratio": _number(row["ratio"], where, "ratio")})
    groups: dict[tuple, list[float]] = {}
    for row in rows:
        if row["known"]:
            key = (row["experiment"], row["shape"], row["engine"])
            groups.setdefault(key, []).append(row["ratio"])
    summary = []
    for (experiment, shape, engine), ratios in groups.items():
        finite = [r for r in ratios if r is not None and math.isfinite(r)]
        summary.append({"experiment": experiment, "shape": shape, "engine": engine,
                        "runs": len(ratios), "not_finite": len(ratios) - len(finite),
                        "median_ratio": float(np.median(finite)) if finite else None})
    return {"present": True, "file": TRANSFER_FILE, "rows": rows, "summary": summary}


__all__ = ["COLUMNS", "ENGINES", "TRANSFER_FILE", "read_transfer"]
