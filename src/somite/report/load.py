"""Read the finished tasks of a campaign: run logs, best genomes, rho curves, cut ratios and
discovered partitions, each by its kind's ``read`` (:mod:`somite.campaigns.kinds`). A finished
task that cannot be read is kept aside with the reason, and the report shows it as missing.
On request, the evolve runs still under way are read too, their logs so far only."""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from ..analysis.stats import RunLog, load_run
from ..brain.genome import Genome
from ..campaigns.kinds import TASK_KINDS
from ..errors import SomiteError
from ..sim.body import PRESET_SHAPES, Shape
from ..sim.config import SimConfig
from .campaign import CampaignFolder

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

    ``runs``, ``bests`` and ``sims``: evolve and reoptimize tasks (``log.csv``, ``best.json``,
    the episode settings of ``config.json``);
    ``transfer``: reoptimize tasks' ``transfer.csv`` rows; ``reassembly``: reassemble tasks'
    ``report.json``; ``discovery``: discover tasks' ``partition.json``; ``broken``: finished
    tasks that could not be read, with why; ``other``: what a kind reads under a name of its
    own; ``under_way``: evolve runs not finished yet, their logs so far (read only when the
    report is asked for them).
    """

    runs: dict[str, RunLog] = field(default_factory=dict)
    bests: dict[str, Genome] = field(default_factory=dict)
    sims: dict[str, SimConfig] = field(default_factory=dict)
    transfer: dict[str, list[dict]] = field(default_factory=dict)
    reassembly: dict[str, dict] = field(default_factory=dict)
    discovery: dict[str, dict] = field(default_factory=dict)
    broken: dict[str, str] = field(default_factory=dict)
    under_way: dict[str, RunLog] = field(default_factory=dict)
    other: dict[str, dict[str, object]] = field(default_factory=dict)
    """What a kind's ``read`` found under a name that is none of the fields above (a new
    kind's own): name -> task id -> value; :meth:`found` reads it."""

    def add(self, task_id: str, found: dict) -> None:
        """What a kind's ``read`` found of a task: name -> the task's value, kept under the
        field of that name, else under ``other``."""
        for name, value in found.items():
            self.found(name)[task_id] = value

    def found(self, name: str) -> dict:
        """Task id -> what the kinds' ``read`` found under ``name``."""
        if name in FIELDS:
            return getattr(self, name)
        return self.other.setdefault(name, {})


FIELDS = tuple(f.name for f in fields(Loaded) if f.name not in ("broken", "other", "under_way"))
"""The fields a kind's ``read`` fills by name."""


def load(campaign: CampaignFolder, under_way: bool = False) -> Loaded:
    """Read every finished task of ``campaign``, and with ``under_way`` the logs of its evolve
    runs that have started and not finished."""
    loaded = Loaded()
    for task in campaign.tasks:
        if not task.done:
            if under_way and task.kind == "evolve":
                _read_under_way(task.id, task.folder, loaded)
            continue
        try:
            loaded.add(task.id, TASK_KINDS[task.kind].read(task.folder, task.options))
        except SomiteError as error:
            loaded.broken[task.id] = str(error)
    return loaded


def _read_under_way(task_id: str, folder, loaded: Loaded) -> None:
    """The log so far of a run still being written; a run that has logged nothing yet (or
    not even made its folder) is simply not under way."""
    if not (folder / "log.csv").is_file():
        return
    try:
        loaded.under_way[task_id] = load_run(folder)
    except SomiteError:
        return


__all__ = ["FIELDS", "Loaded", "load", "shape_name"]
