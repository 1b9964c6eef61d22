"""Read the finished tasks of a campaign: run logs, best genomes, rho curves, cut ratios and
discovered partitions. A finished task that cannot be read is kept aside with the reason, and
the report shows it as missing."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field

from .._io import read_json, read_text
from ..analysis.stats import RunLog, load_run, number
from ..brain.genome import Genome
from ..errors import SomiteError, bad
from ..experiments.config import resolve
from ..sim.body import PRESET_SHAPES, Shape
from .campaign import Campaign, Task

_SHAPE_NAMES = {grid: name for name, grid in PRESET_SHAPES.items()}


def shape_name(spec: str) -> str:
    """``biped`` or ``worm`` for the paper's shapes in any spelling, else the grid string."""
    try:
        grid = Shape.parse(str(spec)).grid_string()
    except SomiteError:
        return str(spec)
    return _SHAPE_NAMES.get(grid, grid)


@dataclass
class Loaded:
    """What the finished tasks hold, by task id.

    ``runs`` and ``bests``: evolve and reoptimize tasks (``log.csv``, ``best.json``);
    ``transfer``: reoptimize tasks' ``transfer.csv`` rows; ``reassembly``: reassemble tasks'
    ``report.json``; ``discovery``: discover tasks' ``partition.json``; ``broken``: finished
    tasks that could not be read, with why.
    """

    runs: dict[str, RunLog] = field(default_factory=dict)
    bests: dict[str, Genome] = field(default_factory=dict)
    transfer: dict[str, list[dict]] = field(default_factory=dict)
    reassembly: dict[str, dict] = field(default_factory=dict)
    discovery: dict[str, dict] = field(default_factory=dict)
    broken: dict[str, str] = field(default_factory=dict)


def load(campaign: Campaign) -> Loaded:
    """Read every finished task of ``campaign``."""
    loaded = Loaded()
    for task in campaign.tasks:
        if not task.done:
            continue
        try:
            _READERS[task.kind](task, loaded)
        except SomiteError as error:
            loaded.broken[task.id] = str(error)
    return loaded


def _run(task: Task, loaded: Loaded) -> None:
    run = load_run(task.folder)
    resolve(run.config)  # the re-run on the validation terrains needs its episode settings
    best = Genome.load(task.folder / "best.json")
    loaded.runs[task.id] = run
    loaded.bests[task.id] = best


def _reoptimized(task: Task, loaded: Loaded) -> None:
    rows = read_transfer(task)
    _run(task, loaded)
    loaded.transfer[task.id] = rows


def read_transfer(task: Task) -> list[dict]:
    """``transfer.csv`` as rows of floats (generation, training and validation v_x, rho)."""
    path = task.folder / "transfer.csv"
    text = read_text(path, "transfer")
    reader = csv.DictReader(text.splitlines())
    if "rho" not in (reader.fieldnames or ()) or "generation" not in reader.fieldnames:
        raise bad("transfer", str(path), "lacks the columns generation and rho")
    rows = [{k: number(v) for k, v in row.items()} for row in reader]
    if not rows:
        raise bad("transfer", str(path), "has no rows")
    return rows


def _reassembled(task: Task, loaded: Loaded) -> None:
    report = read_json(task.folder / "report.json", "reassembly")
    if not isinstance(report, dict) or not isinstance(report.get("pooled"), dict):
        raise bad("reassembly", str(task.folder / "report.json"), "not a reassemble report")
    loaded.reassembly[task.id] = report


def _discovered(task: Task, loaded: Loaded) -> None:
    from ..sim.partition import Partition

    path = task.folder / "partition.json"
    data = read_json(path, "partition")
    partition = Partition.from_dict(data, where=str(path))
    if not isinstance(data.get("best"), dict):
        raise bad("partition", str(path), "lacks the discovered module (best)")
    loaded.discovery[task.id] = {**data, "partition": partition}


_READERS = {"evolve": _run, "reoptimize": _reoptimized, "reassemble": _reassembled,
            "discover": _discovered}


__all__ = ["Loaded", "load", "read_transfer", "shape_name"]
