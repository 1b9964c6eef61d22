"""A campaign directory as the report reads it (the layout: :mod:`somite.campaigns.directory`).

``DIR/campaign.json`` lists the tasks; ``DIR/<task path>/done.json`` marks a finished one. The
report trusts nothing else: a task without ``done.json`` is *missing* (its folder may hold a
partial run), and so is a finished task whose files cannot be read (with the reason). Which
experiment feeds which figure is each experiment's ``figures`` (:mod:`somite.campaigns.figures`);
a ``campaign.json`` written before experiments declared them is read with the built-ins'
declarations (:data:`somite.campaigns.builtin.DECLARED_FIGURES`), and a built-in campaign's
folder also with the figures its built-in declares now and the folder's file lacks (a figure
added to the report while the campaign ran).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from ..campaigns import figures as figure_table
from ..campaigns.builtin import DECLARED_FIGURES, builtin, is_builtin
from ..campaigns.directory import read
from ..campaigns.kinds import TASK_KINDS
from ..campaigns.layout import read_done
from ..errors import SomiteError, bad


@dataclass(frozen=True)
class Task:
    """One task of ``campaign.json``; ``folder`` is absolute, ``done`` whether it finished."""

    id: str
    experiment: str
    kind: str
    folder: Path
    needs: tuple[str, ...]
    options: dict = field(repr=False)
    done: bool

    @property
    def name(self) -> str:
        """The task's name inside its experiment (``biped-s0``)."""
        return self.id.split("/", 1)[-1]

    @property
    def variant(self) -> str:
        """The variant of an evolve experiment's grid that made the task (``""``: none). Its
        name is ``<variant>-<shape>-s<seed>`` (:mod:`somite.campaigns.kinds.evolve`), and
        ``campaign.json`` keeps no other record of it."""
        tail = f"-{self.options.get('shape')}-s{self.options.get('seed')}"
        if self.kind != "evolve" or not self.name.endswith(tail) or self.name == tail[1:]:
            return ""
        return self.name[:-len(tail)]


@dataclass(frozen=True)
class CampaignFolder:
    """A campaign folder as read for its report (a campaign file is
    :class:`somite.campaigns.spec.Campaign`): its name, experiments (id -> title, paper
    reference and figures), tasks and ``figures``: figure -> experiment -> its group's label
    there."""

    root: Path
    name: str
    source: str
    experiments: dict[str, dict]
    tasks: tuple[Task, ...]
    figures: dict[str, dict[str, str]] = field(default_factory=dict)
    declared: bool = True
    """Whether the campaign declares its figures; where it declares none (a campaign file
    without ``figures`` tables), ``figures`` is what the report can show (:func:`shown`)."""

    def fed(self, figure: str) -> dict[str, str]:
        """The experiments that feed ``figure``, each with its label, in the campaign's order."""
        return self.figures.get(figure, {})

    def variants(self, experiment: str) -> list[str]:
        """The variants of ``experiment``'s grid, in the file's order (``[""]``: none)."""
        found = list(dict.fromkeys(t.variant for t in self.of(experiment)))
        return found or [""]

    def missing_figures(self) -> dict[str, str]:
        """Figure -> why no experiment feeds it (none where the campaign declares none: the
        report says so in one line instead)."""
        if not self.declared:
            return {}
        return figure_table.missing(self.figures, {e: len(self.variants(e))
                                                   for e in self.experiments})

    def task(self, task_id: str) -> Task | None:
        return next((t for t in self.tasks if t.id == task_id), None)

    def of(self, experiment: str, kind: str | None = None) -> list[Task]:
        """The tasks of ``experiment`` (of ``kind``), in the file's order."""
        return [t for t in self.tasks
                if t.experiment == experiment and (kind is None or t.kind == kind)]

    def of_kind(self, kind: str) -> list[Task]:
        """The tasks of ``kind``, in the file's order."""
        return [t for t in self.tasks if t.kind == kind]

    def status(self, unreadable=()) -> dict:
        """Per experiment: tasks, finished, and the ids of the missing ones (unfinished, or
        among ``unreadable``)."""
        table = {}
        for experiment in self.experiments:
            tasks = self.of(experiment)
            missing = [t.id for t in tasks if not t.done or t.id in unreadable]
            table[experiment] = {"tasks": len(tasks), "done": len(tasks) - len(missing),
                                 "missing": missing}
        return table


def read_campaign(root: str | Path) -> CampaignFolder:
    """Read ``root/campaign.json``; anything malformed is a one-line error."""
    root = Path(root)
    if not root.is_dir():
        raise bad("campaign", str(root), "no such campaign directory")
    data = read(root)
    experiments = data.get("experiments", {})
    if not isinstance(experiments, dict) or not all(
        isinstance(v, dict) for v in experiments.values()
    ):
        raise bad("campaign.experiments", experiments, "expected an object of objects")
    tasks, seen = [], set()
    for item in data["tasks"]:
        task = _task(root, item)
        if task.id in seen:
            raise bad("campaign.tasks.id", task.id, "listed twice")
        seen.add(task.id)
        tasks.append(task)
    # Experiments that only the tasks name still get a section.
    for task in tasks:
        experiments.setdefault(task.experiment, {})
    figures = _figures(experiments, str(data.get("source", "")))
    if not figures:
        return CampaignFolder(root, str(data.get("name", root.name)),
                              str(data.get("source", "")), experiments, tuple(tasks),
                              shown(tasks), declared=False)
    return CampaignFolder(root, str(data.get("name", root.name)), str(data.get("source", "")),
                          experiments, tuple(tasks), figures)


def _figures(experiments: dict[str, dict], source: str) -> dict[str, dict[str, str]]:
    if any("figures" in info for info in experiments.values()):
        declared = {name: info.get("figures", {}) for name, info in experiments.items()}
    else:  # written before experiments declared their figures: the built-ins' names
        declared = {name: DECLARED_FIGURES[name] for name in experiments
                    if name in DECLARED_FIGURES}
    now = _builtin_figures(source)
    return figure_table.declared({name: _with(declared.get(name, {}), now.get(name, {}))
                                  for name in experiments})


def _with(held: dict[str, str], now: dict[str, str]) -> dict[str, str]:
    """An experiment's declaration as its folder ``held`` it, and the figures of ``now`` it
    lacks after them."""
    return {**held, **{name: label for name, label in now.items() if name not in held}}


def _builtin_figures(source: str) -> dict[str, dict[str, str]]:
    """Experiment -> the figures it declares in the built-in campaign ``source`` names
    (``builtin:lengths``) as this version of somite writes it; nothing for a file's campaign
    or a built-in this version lacks. The lengths campaign started before its experiments
    declared ``edge-lengths``: its folder keeps the declarations it was written with."""
    prefix, _, name = source.partition(":")
    if prefix != "builtin" or not is_builtin(name):
        return {}
    try:
        return {e.name: dict(e.figures) for e in builtin(name).experiments}
    except SomiteError:
        return {}


def shown(tasks) -> dict[str, dict[str, str]]:
    """What the report shows of a campaign that declares no figure: every evolve experiment
    in Figures 3 and 5 (a group per experiment and variant) and every reassembly in Figure 7,
    each under its own name; nothing beside the paper's numbers (Table 1 has a row per
    experiment, variant and shape anyway)."""
    fed: dict[str, dict[str, str]] = {}
    for task in tasks:
        for figure in {"evolve": ("figure3", "figure5"), "reassemble": ("figure7",)}.get(
                task.kind, ()):
            fed.setdefault(figure, {})[task.experiment] = task.experiment
    return fed


def _task(root: Path, item) -> Task:
    if not isinstance(item, dict):
        raise bad("campaign.tasks", item, "a task must be an object")
    for key in ("id", "experiment", "kind", "path"):
        if not isinstance(item.get(key), str) or not item[key]:
            raise bad(f"campaign.tasks.{key}", item.get(key), "must be a non-empty string")
    if item["kind"] not in TASK_KINDS:
        raise bad("campaign.tasks.kind", item["kind"], f"use one of {list(TASK_KINDS)}")
    relative = PurePosixPath(item["path"])
    if relative.is_absolute() or ".." in relative.parts:
        raise bad("campaign.tasks.path", item["path"], "must be relative, inside the campaign")
    needs = item.get("needs", [])
    options = item.get("options", {})
    if not isinstance(needs, list) or not all(isinstance(n, str) for n in needs):
        raise bad("campaign.tasks.needs", needs, "expected a list of task ids")
    if not isinstance(options, dict):
        raise bad("campaign.tasks.options", options, "expected an object")
    folder = root / relative
    return Task(item["id"], item["experiment"], item["kind"], folder, tuple(needs), options,
                read_done(folder) is not None)


def task_row(task: Task, done: bool) -> dict:
    """The start of a task's row in a report table."""
    return {"task": task.id, "experiment": task.experiment, "done": done}


__all__ = ["CampaignFolder", "Task", "read_campaign", "task_row"]
