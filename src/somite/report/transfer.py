"""The transfer section: every final best re-run in the paper's simulator (2D-VSR-Sim), its
velocity there over its velocity in somite, per run.

somite does not run Java. ``benchmarks/transfer.py`` does (the driver of
``shared/tools/closed-loop-2dvsrsim/``), once with dyn4j as shipped (``stock``) and once with
its continuous collision detection off (``noccd``, where it misfires against the terrain); its
per-run ratios go into ``transfer.csv`` at the top of the campaign folder (so that a pack
carries them), one row per run, engine and sensors::

    task,engine,sensors,generation,somite_vx,vsr_vx,ratio,somite_own_vx,overall_ratio
    rq1/biped-s0,stock,code,3000,3.1,2.9,0.94,4.1,0.71
    rq1/biped-s0,stock,own,3000,4.1,3.9,0.95,4.1,0.95

``sensors`` is what the driver read: ``code``, the authors' code's sensors for every run, or
``own``, each run's own preset's (a variant of the driver). ``somite_vx`` is somite on the
sensors the driver read, so ``ratio`` = vsr_vx / somite_vx compares the physics alone;
``somite_own_vx`` is somite on the run's own sensors and ``overall_ratio`` = vsr_vx /
somite_own_vx what the run keeps of its speed in the paper's simulator (with ``own`` the two
ratios are one). ``generation``, the velocities and the last two columns may be empty, and
``sensors`` absent (a file written before they existed: ``code``). The report shows the file's
rows beside the runs and the median ratios per experiment, shape, engine and sensors, and
flags a ratio whose denominator is near zero (:data:`NEAR_ZERO`); without the file it says how
to make it.
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
COLUMNS = ("task", "engine", "sensors", "generation", "somite_vx", "vsr_vx", "ratio",
           "somite_own_vx", "overall_ratio")
ENGINES = ("stock", "noccd")
SENSORS = ("code", "own")
NEAR_ZERO = 0.5
"""[m/s] A ratio whose denominator (somite's v_x) is smaller than this in magnitude is flagged:
over the 25 s that v_x is measured on, a robot that slow has moved a few metres at most, and a
difference of centimetres between the simulators makes ratios like -108 or 4.6."""


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
        sensors = row.get("sensors") or "code"
        if sensors not in SENSORS:
            raise bad("transfer", where, f"sensors={sensors!r}: use one of {SENSORS}")
        experiment, shape = tasks.get(row["task"], ("", ""))
        rows.append({"task": row["task"], "experiment": experiment, "shape": shape,
                     "known": row["task"] in tasks, "engine": row["engine"],
                     "sensors": sensors,
                     "generation": _number(row.get("generation") or "", where, "generation"),
                     "somite_vx": _number(row.get("somite_vx") or "", where, "somite_vx"),
                     "vsr_vx": _number(row.get("vsr_vx") or "", where, "vsr_vx"),
                     "ratio": _number(row["ratio"], where, "ratio"),
                     **{name: _number(row.get(name) or "", where, name)
                        for name in ("somite_own_vx", "overall_ratio")}})
        last = rows[-1]
        last["ratio_near_zero"] = _near_zero(last["somite_vx"])
        last["overall_near_zero"] = _near_zero(last["somite_own_vx"])
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        if row["known"]:
            key = (row["experiment"], row["shape"], row["engine"], row["sensors"])
            groups.setdefault(key, []).append(row)
    summary = []
    for (experiment, shape, engine, sensors), members in groups.items():
        ratios = [m["ratio"] for m in members]
        finite = _finite(ratios)
        summary.append({"experiment": experiment, "shape": shape, "engine": engine,
                        "sensors": sensors,
                        "runs": len(ratios), "not_finite": len(ratios) - len(finite),
                        "near_zero": sum(m["ratio_near_zero"] for m in members),
                        "median_ratio": _median(finite),
                        "median_overall_ratio": _median(_finite(
                            m["overall_ratio"] for m in members))})
    return {"present": True, "file": TRANSFER_FILE, "rows": rows, "summary": summary}


def _near_zero(velocity: float | None) -> bool:
    """Whether a ratio over ``velocity`` is flagged (:data:`NEAR_ZERO`)."""
    return velocity is not None and abs(velocity) < NEAR_ZERO


def _finite(values) -> list[float]:
    return [v for v in values if v is not None and math.isfinite(v)]


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


__all__ = ["COLUMNS", "ENGINES", "NEAR_ZERO", "SENSORS", "TRANSFER_FILE", "read_transfer"]
