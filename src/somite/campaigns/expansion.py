"""A campaign expanded into tasks: one per run directory, reassembly or discovery.

A task is plain data (it travels to Dask workers and into ``campaign.json``)::

    {"id": "rq1/worm-s0", "experiment": "rq1", "kind": "evolve", "path": "rq1/worm-s0",
     "needs": [...], "options": {...}}

Every option is resolved here, defaults included, so that the task list alone says what ran,
and checked here, before ``campaign.json`` is written: what a task would refuse when it runs is
refused now. Each experiment is expanded by its kind (:mod:`.kinds`): evolve and
re-optimisation options are a run's ``config.json`` (plus ``representation``, and for a
re-optimisation ``donors`` and ``validation``), each resolved by
:func:`~.kinds.common.run_config`; the other options name tasks by id and partitions by
preset, by grid, by a discovery's ``partition.json`` relative to the campaign directory, or by
the absolute path of a file the campaign file names (:mod:`.spec`). Task ids are unique (two
tasks of one id: the campaign is refused).
"""

from __future__ import annotations

from ..errors import bad
from .kinds import TASK_KINDS
from .spec import Campaign


def expand(campaign: Campaign) -> list[dict]:
    """Every task of ``campaign``, each after the tasks it needs."""
    tasks: list[dict] = []
    grids: dict[str, object] = {}
    """experiment -> what its expansion gives the experiments after it (an evolve
    experiment's grid of runs: variant -> shape -> [(seed, task)])"""
    for exp in campaign.experiments:
        made, grids[exp.name] = TASK_KINDS[exp.kind].expand(campaign, exp, grids)
        tasks += made
    _unique(tasks)
    return tasks


def _unique(tasks: list[dict]) -> None:
    """Refuse two tasks of one id (one would never run): the names an experiment makes of
    donor experiments, variants and shapes can meet (donors ``omega-10`` and ``omega``, whose
    variant ``10`` makes ``omega-10-worm-...`` too)."""
    seen: set[str] = set()
    for task in tasks:
        if task["id"] in seen:
            raise bad(f"experiments.{task['experiment']}", task["id"],
                      "a task id this experiment makes twice (one would never run); rename a "
                      "variant or an experiment")
        seen.add(task["id"])


__all__ = ["expand"]
