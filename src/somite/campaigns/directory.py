"""A campaign directory: ``campaign.json``, one folder per task, and each task's state.

The layout is the contract between ``somite campaign run`` and ``somite report``: ``campaign.json``
(written before any task starts) lists the tasks in dependency order, with every option
resolved; ``<task path>/done.json``, written last, says a task is finished. Everything else in
a task's folder is what the matching command writes, and may be partial while it runs.

``campaign.json`` is checked as a whole whenever it is read (:func:`read`, :func:`check_document`),
before anything runs or is printed: every field there with its type, no other; experiment names
as a campaign file's; every task's ``id`` its experiment's name, ``/`` and a name, unique; its
``path`` its id (tasks find each other's folders by id), relative, normalised and inside the
campaign folder, symbolic links followed, and no task's folder inside another's; ``needs``
naming tasks listed before it. ``campaign run`` also checks every task's options
(:func:`check_runnable`). Anything else is a one-line error naming the field
(``campaign.json: tasks[3].path``).
"""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

from .. import formats
from .._io import check_output_folder, read_json, write_atomic
from ..errors import SomiteError, bad
from ..experiments.lock import LOCK_NAME, read_holder
from .fields import check_name
from .figures import FIGURES
from .kinds import TASK_KINDS, needs
from .layout import CAMPAIGN, read_done
from .layout import at as _at
from .layout import inside as _inside
from .spec import Campaign

FIELDS = {"format": str, "version": int, "name": str, "source": str, "experiments": dict,
          "tasks": list}
"""The fields of ``campaign.json``, each with its type."""
TASK_FIELDS = {"id": str, "experiment": str, "kind": str, "path": str, "needs": list,
               "options": dict}
"""The fields of a task, each with its type."""
EXPERIMENT_FIELDS = {"title": str, "paper": str, "figures": dict}
"""The fields of an experiment in ``campaign.json`` (``figures``: none in older files)."""


def document(campaign: Campaign, tasks: list[dict]) -> dict:
    """The content of ``campaign.json``."""
    return {**formats.CAMPAIGN.header(), "name": campaign.name,
            "source": campaign.source,
            "experiments": {e.name: {"title": e.title, "paper": e.paper,
                                     "figures": e.figures} for e in campaign.experiments},
            "tasks": tasks}


def read(directory: str | Path) -> dict:
    """``campaign.json`` of ``directory``, checked (:func:`check_document`), or a one-line
    error."""
    path = Path(directory) / CAMPAIGN
    if not path.is_file():
        raise bad("campaign", str(directory), "holds no campaign.json (not a campaign directory)")
    data = read_json(path, "campaign")
    formats.CAMPAIGN.check(data, prefix="campaign.")
    check_document(data, directory)
    return data


def _typed(table: dict, fields: dict[str, type], where: str) -> None:
    """Every key of ``fields`` in ``table`` with its type (ints are not bools), no other."""
    for key, value in table.items():
        if key not in fields:
            raise bad(_at(where + key), value, f"unknown field (use {', '.join(fields)})")
    for key, kind in fields.items():
        if key not in table:
            raise bad(_at(where + key), None, "required")
        value = table[key]
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise bad(_at(where + key), value, f"must be of type {kind.__name__}")


def check_document(doc: dict, directory: str | Path | None = None) -> None:
    """Check the content of a ``campaign.json`` as a whole (see the module docstring); with
    ``directory``, also that no task's folder leads outside it through a symbolic link."""
    if not isinstance(doc, dict):
        raise bad("campaign", type(doc).__name__, "not a somite campaign.json")
    _typed(doc, FIELDS, "")
    formats.CAMPAIGN.check(doc, prefix=_at(""))
    for name, info in doc["experiments"].items():
        try:
            check_name("experiments", name)
        except SomiteError as error:
            raise SomiteError(_at(str(error))) from None
        if not isinstance(info, dict):
            raise bad(_at(f"experiments.{name}"), info,
                      f"expected an object ({', '.join(EXPERIMENT_FIELDS)})")
        for key, value in info.items():
            if key not in EXPERIMENT_FIELDS:
                raise bad(_at(f"experiments.{name}.{key}"), value,
                          f"unknown field (use {', '.join(EXPERIMENT_FIELDS)})")
            if not isinstance(value, EXPERIMENT_FIELDS[key]):
                raise bad(_at(f"experiments.{name}.{key}"), value,
                          f"must be of type {EXPERIMENT_FIELDS[key].__name__}")
        if "figures" in info:
            _figures(f"experiments.{name}.figures", info["figures"])
    tasks = doc["tasks"]
    listed = {t.get("id") for t in tasks if isinstance(t, dict) and isinstance(t.get("id"), str)}
    index: dict[str, int] = {}
    for i, task in enumerate(tasks):
        where = f"tasks[{i}]"
        if not isinstance(task, dict):
            raise bad(_at(where), task, f"a task is an object ({', '.join(TASK_FIELDS)})")
        _typed(task, TASK_FIELDS, where + ".")
        if task["kind"] not in TASK_KINDS:
            raise bad(_at(where + ".kind"), task["kind"], f"use one of {list(TASK_KINDS)}")
        if task["experiment"] not in doc["experiments"]:
            raise bad(_at(where + ".experiment"), task["experiment"],
                      "not one of the campaign's experiments")
        _inside(where + ".path", task["path"])
        _inside(where + ".id", task["id"])
        group, _, name = task["id"].partition("/")
        if group != task["experiment"] or not name:
            raise bad(_at(where + ".id"), task["id"],
                      f"must be {task['experiment']}/NAME (its experiment, '/', a name)")
        if task["path"] != task["id"]:
            raise bad(_at(where + ".path"), task["path"],
                      f"must be the task's id {task['id']!r} (tasks find each other's folders "
                      "by id)")
        if task["id"] in index:
            raise bad(_at(where + ".id"), task["id"],
                      f"tasks[{index[task['id']]}] has this id too (one would never run)")
        for need in task["needs"]:
            if not isinstance(need, str) or need not in listed:
                raise bad(_at(where + ".needs"), need, "no such task")
            if need == task["id"]:
                raise bad(_at(where + ".needs"), need, "the task itself")
            if need not in index:
                raise bad(_at(where + ".needs"), need, "listed after this task (campaign.json "
                          "lists the tasks in dependency order)")
        index[task["id"]] = i
    _apart([t["path"] for t in tasks], "")
    if directory is not None:
        root = Path(directory).resolve()
        real = []
        for i, task in enumerate(tasks):
            try:
                folder = (root / task["path"]).resolve()
            except (OSError, RuntimeError):  # a loop of symbolic links
                raise bad(_at(f"tasks[{i}].path"), task["path"], "must be a relative path "
                          "inside the campaign folder (symbolic links loop there)") from None
            if folder == root or root not in folder.parents:
                raise bad(_at(f"tasks[{i}].path"), task["path"],
                          "must be a relative path inside the campaign folder (a symbolic link "
                          f"leads it to {folder})")
            real.append(folder.relative_to(root).as_posix())
        _apart(real, " (symbolic links followed)")


def _figures(where: str, declared: dict) -> None:
    """An experiment's ``figures``: figure names of the report, each with a label."""
    for name, label in declared.items():
        if name not in FIGURES or not isinstance(label, str):
            raise bad(_at(f"{where}.{name}"), label,
                      f"a label (str) of one of the figures {', '.join(FIGURES)}")


def _apart(paths: list[str], how: str) -> None:
    """No two tasks of one folder, and none inside another's (file systems may ignore case)."""
    folded: dict[str, int] = {}
    for i, path in enumerate(paths):
        key = path.casefold()
        if key in folded:
            raise bad(_at(f"tasks[{i}].path"), path,
                      f"the folder of tasks[{folded[key]}] too{how}")
        folded[key] = i
    for i, path in enumerate(paths):
        parts = path.casefold().split("/")
        for k in range(1, len(parts)):
            j = folded.get("/".join(parts[:k]))
            if j is not None:
                raise bad(_at(f"tasks[{i}].path"), path,
                          f"inside the folder of tasks[{j}] ({paths[j]}){how}")


def check_runnable(doc: dict) -> None:
    """Check every task's options (a checked document, :func:`check_document`): what its
    runner (:mod:`.work`) reads is there, of its type and value, and the tasks it reads from
    are tasks it needs, of the kind that writes what it reads. ``campaign run`` calls this
    before it writes or starts anything: a task of options made by hand fails here, in one
    line, not on a worker."""
    context = needs(doc["tasks"])
    for i, task in enumerate(doc["tasks"]):
        where = f"tasks[{i}].options"
        try:
            TASK_KINDS[task["kind"]].check(where, task, context)
        except SomiteError as error:
            text = str(error)
            if not text.startswith(CAMPAIGN):
                text = _at(f"{where}.{text}")
            raise SomiteError(text) from None


def prepare(directory: str | Path, doc: dict | None, resume: bool, write: bool = True) -> dict:
    """Check ``directory`` for running ``doc`` (None: the campaign already there, with
    ``resume``) and (``write``) write ``campaign.json`` if it has none; returns the document
    to run.

    Without ``resume`` a directory must be empty (a campaign there is refused: ``--resume``
    continues it); with it, a campaign there must be this one: the same tasks, or (more
    seeds, ``paper-rq1:10`` after ``paper-rq1``; a larger built-in, ``paper:3`` after
    ``paper-rq1``) every task there unchanged among more, which are added to ``campaign.json``
    (``write``), the tasks there resuming as they were."""
    if doc is not None:
        check_document(doc)
    directory = check_output_folder(directory)
    held = directory / CAMPAIGN
    if held.exists():
        there = read(directory)
        if doc is None:
            return there
        if not resume:
            raise bad("out", str(directory), f"holds campaign {there.get('name')!r} already; "
                      "--resume continues it, or give another folder")
        if _by_id(there["tasks"]) == _by_id(doc["tasks"]):
            return there  # the same tasks (a built-in reordered since keeps the folder's order)
        if not _grows(there, doc):
            raise bad("out", str(directory), f"holds campaign {there.get('name')!r}, whose "
                      "tasks are not this campaign's; give another folder")
        if write:
            write_atomic(held, json.dumps(doc, indent=1) + "\n")
        return doc
    if doc is None:
        raise bad("campaign", str(directory), "holds no campaign.json: name the campaign to run")
    if directory.is_dir():
        others = sorted(p.name for p in directory.iterdir() if p.name != LOCK_NAME)
        if others:
            raise bad("out", str(directory), f"is not empty (holds {others[0]}) and holds no "
                      "campaign; give an empty or new folder")
    if write:
        directory.mkdir(parents=True, exist_ok=True)
        write_atomic(held, json.dumps(doc, indent=1) + "\n")
    return doc


def _by_id(tasks: list) -> dict:
    return {task["id"]: task for task in tasks}


def _grows(there: dict, doc: dict) -> bool:
    """Whether ``doc`` is the campaign ``there`` with tasks added (more seeds), or a built-in
    that holds ``there``'s built-in (``paper`` over ``paper-rq1``, :data:`~.builtin
    .GROWS_FROM`), every task of ``there`` in it unchanged."""
    from .builtin import GROWS_FROM

    tasks = {t["id"]: t for t in doc["tasks"]}
    same = there.get("name") == doc.get("name") or (
        there.get("name") in GROWS_FROM.get(doc.get("name"), ())
        and str(doc.get("source", "")).startswith("builtin:"))
    return same and len(tasks) > len(there["tasks"]) and all(
        tasks.get(t["id"]) == t for t in there["tasks"])


RESUMABLE = ("evolve", "reoptimize")
"""The kinds whose tasks are runs that resume from a checkpoint (the others start again)."""


def physics_to_force(directory: Path, doc: dict, force: bool) -> list[tuple[Path, str]]:
    """Check, as ``--resume`` of each run would (:func:`~somite.experiments.physics
    .check_resume`), that every unfinished run of ``doc`` with a checkpoint ran under this
    somite's physics: one that did not is refused in one line naming both physics, unless
    ``force``; then returns each such run's folder and the ``physics.json`` that records the
    forced resume, for the caller to write once it holds the campaign."""
    from ..experiments.physics import check_resume

    forced = []
    for task in doc["tasks"]:
        folder = directory / task["path"]
        checkpoint = folder / "checkpoint.json"
        if task["kind"] not in RESUMABLE or finished(directory, task) or not \
                checkpoint.is_file():
            continue
        generation = read_json(checkpoint, "checkpoint").get("generation")
        text = check_resume(folder, force, generation if isinstance(generation, int) else -1)
        if text is not None:
            forced.append((folder, text))
    return forced


def finished(directory: Path, task: dict) -> bool:
    return read_done(directory / task["path"]) is not None


def state(directory: Path, task: dict) -> dict:
    """What the disk says of ``task``: ``state`` (done, running, partial or queued),
    ``generation`` and ``generations`` (runs), ``best`` (a run's logged best v_x so far, the
    luckiest terrain draw), ``validation`` (its mean v_x on the validation terrains, the last
    the log measured; a reassembly's v_x there) and ``done`` (its done.json, if any)."""
    folder = directory / task["path"]
    options = task["options"]
    info = {"id": task["id"], "kind": task["kind"], "state": "queued", "generation": None,
            "generations": options.get("generations"), "best": None, "validation": None,
            "done": None}
    if not folder.is_dir():
        return info
    record = read_done(folder)
    if record is not None:
        info["state"] = "done"
        info["done"] = record
    elif _alive(folder / LOCK_NAME):
        info["state"] = "running"
    else:
        info["state"] = "partial"
    info.update(TASK_KINDS[task["kind"]].progress(folder, options, info["state"] == "done"))
    return info


def _alive(lock: Path) -> bool:
    """Whether the lock file names a live process (one on another host is taken as live).
    Read as the lock reads it (:func:`~somite.experiments.lock.read_holder`): never through a
    link, never waiting on a FIFO."""
    holder = read_holder(lock)
    if holder is None:
        return False
    pid, host = holder["pid"], holder["host"]
    if host != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
