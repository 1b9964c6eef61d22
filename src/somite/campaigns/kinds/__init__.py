"""The campaign task kinds, in one registry (Gymnasium's pattern): ``{kind: TaskKind}``.

A kind says how a campaign file's experiment of that kind is checked (``fields``, ``parse``)
and expanded into tasks (``expand``); how a task of it runs on a worker (``run``, returning
its robot-control-steps), what ``campaign run`` checks of its options first (``check``), what
a finished one holds (``outputs``) and what the report reads of it (``read``, whose keys are
the fields of :class:`somite.report.load.Loaded`), how far it has got (``progress``) and what
it will cost (``estimate``, robot-control-steps). A kind without ``expand`` is made by
another kind's experiment (a re-optimisation by a reassembly's). The campaign file, the
task list, ``campaign.json``'s checks, the workers, the progress view, ``campaign list`` and
the report all read this registry: a new kind is its module and its place in ``MODULES``
(nothing else here names it). What a kind of experiment adds to the report (its figures,
tables and text) is its section there, listed by kind in ``somite/report/sections.py``
(docs/architecture.md, "Where a new thing goes").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ...errors import bad
from . import discover, evolve, reassemble, reoptimize
from .common import Needs


@dataclass(frozen=True)
class TaskKind:
    """One kind of campaign task (see the module docstring)."""

    run: Callable[[Path, Path, dict], int]
    check: Callable[[str, dict, Needs], None]
    read: Callable[[Path, dict], dict]
    progress: Callable[[Path, dict, bool], dict]
    estimate: Callable[[dict], int]
    outputs: frozenset[str]
    expand: Callable | None = None
    parse: Callable | None = None
    fields: frozenset[str] = frozenset()


    @classmethod
    def of(cls, module) -> TaskKind:
        """The kind that ``module`` (of this package) defines, read by name: its functions
        ``run``, ``check``, ``read``, ``progress``, ``estimate`` and ``OUTPUTS``; ``expand``,
        ``parse`` and ``FIELDS`` if an experiment of a campaign file may have it."""
        optional = {name: getattr(module, name) for name in ("expand", "parse", "FIELDS")
                    if hasattr(module, name)}
        return cls(module.run, module.check, module.read, module.progress, module.estimate,
                   module.OUTPUTS, **{name.lower(): value for name, value in optional.items()})


MODULES = (evolve, reassemble, reoptimize, discover)
"""The kinds' modules, in the order tables list them; a kind is named after its module."""

TASK_KINDS: dict[str, TaskKind] = {module.__name__.rpartition(".")[2]: TaskKind.of(module)
                                   for module in MODULES}
"""Every task kind, in the order tables list them."""

EXPERIMENT_KINDS = tuple(name for name, kind in TASK_KINDS.items() if kind.expand is not None)
"""The kinds a campaign file's experiment may have."""


def kind(name: str, field: str) -> TaskKind:
    """The kind ``name``, or a one-line error naming ``field``."""
    if name not in TASK_KINDS:
        raise bad(field, name, f"use one of {list(TASK_KINDS)}")
    return TASK_KINDS[name]


def needs(tasks: list[dict]) -> Needs:
    """What the checks of ``tasks``' options ask of the tasks they read from."""
    return Needs({t["id"]: t for t in tasks}, {k: v.outputs for k, v in TASK_KINDS.items()})


def estimate(task: dict) -> int:
    """Robot-control-steps ``task`` will take."""
    return TASK_KINDS[task["kind"]].estimate(task["options"])


__all__ = ["EXPERIMENT_KINDS", "TASK_KINDS", "TaskKind", "estimate", "kind", "needs"]
