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

import csv
import io
import json
import os
import socket
from pathlib import Path, PurePosixPath

from .._io import check_output_folder, read_json, write_atomic
from ..errors import SomiteError, bad
from ..experiments.lock import LOCK_NAME, read_holder
from .spec import Campaign, check_name
from .tasks import RUN_EXTRAS
from .work import DONE

FORMAT = "somite-campaign"
VERSION = 1
CAMPAIGN = "campaign.json"
KINDS = ("evolve", "reassemble", "reoptimize", "discover")
FIELDS = {"format": str, "version": int, "name": str, "source": str, "experiments": dict,
          "tasks": list}
"""The fields of ``campaign.json``, each with its type."""
TASK_FIELDS = {"id": str, "experiment": str, "kind": str, "path": str, "needs": list,
               "options": dict}
"""The fields of a task, each with its type."""
MAX_FOLDER_NAME = 255
"""Bytes of one folder name (most file systems' limit)."""


def document(campaign: Campaign, tasks: list[dict]) -> dict:
    """The content of ``campaign.json``."""
    return {"format": FORMAT, "version": VERSION, "name": campaign.name,
            "source": campaign.source,
            "experiments": {e.name: {"title": e.title, "paper": e.paper}
                            for e in campaign.experiments},
            "tasks": tasks}


def read(directory: str | Path) -> dict:
    """``campaign.json`` of ``directory``, checked (:func:`check_document`), or a one-line
    error."""
    path = Path(directory) / CAMPAIGN
    if not path.is_file():
        raise bad("campaign", str(directory), "holds no campaign.json (not a campaign directory)")
    data = read_json(path, "campaign")
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise bad("campaign", str(path), "not a somite campaign.json")
    if data.get("version") != VERSION:
        raise bad("campaign.version", data.get("version"), f"this somite reads {VERSION}")
    check_document(data, directory)
    return data


def _at(where: str) -> str:
    """The name of a field of ``campaign.json`` in an error."""
    return f"{CAMPAIGN}: {where}"


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


def _path_problem(text: str) -> str | None:
    """Why ``text`` is not a normalised relative path inside a campaign folder, or None."""
    if any(ord(c) < 32 or c == "\\" for c in text):
        return "no backslashes or control characters"
    if PurePosixPath(text).is_absolute():
        return "not absolute"
    parts = text.split("/")
    if ".." in parts:
        return "no '..'"
    if any(part in ("", ".") for part in parts):
        return "normalised: no empty or '.' parts"
    if any(len(part.encode()) > MAX_FOLDER_NAME for part in parts):
        return f"folder names of at most {MAX_FOLDER_NAME} bytes"
    if parts[0] in (CAMPAIGN, LOCK_NAME):
        return f"not the campaign folder's own {parts[0]}"
    return None


def _inside(where: str, text: str) -> None:
    problem = _path_problem(text)
    if problem is not None:
        raise bad(_at(where), text,
                  f"must be a relative path inside the campaign folder ({problem})")


def check_document(doc: dict, directory: str | Path | None = None) -> None:
    """Check the content of a ``campaign.json`` as a whole (see the module docstring); with
    ``directory``, also that no task's folder leads outside it through a symbolic link."""
    if not isinstance(doc, dict):
        raise bad("campaign", type(doc).__name__, "not a somite campaign.json")
    _typed(doc, FIELDS, "")
    if doc["format"] != FORMAT:
        raise bad(_at("format"), doc["format"], f"not {FORMAT!r}")
    if doc["version"] != VERSION:
        raise bad(_at("version"), doc["version"], f"this somite reads {VERSION}")
    for name, info in doc["experiments"].items():
        try:
            check_name("experiments", name)
        except SomiteError as error:
            raise SomiteError(_at(str(error))) from None
        if not isinstance(info, dict):
            raise bad(_at(f"experiments.{name}"), info, "expected an object (title, paper)")
        for key, value in info.items():
            if key not in ("title", "paper"):
                raise bad(_at(f"experiments.{name}.{key}"), value,
                          "unknown field (use title, paper)")
            if not isinstance(value, str):
                raise bad(_at(f"experiments.{name}.{key}"), value, "must be of type str")
    tasks = doc["tasks"]
    listed = {t.get("id") for t in tasks if isinstance(t, dict) and isinstance(t.get("id"), str)}
    index: dict[str, int] = {}
    for i, task in enumerate(tasks):
        where = f"tasks[{i}]"
        if not isinstance(task, dict):
            raise bad(_at(where), task, f"a task is an object ({', '.join(TASK_FIELDS)})")
        _typed(task, TASK_FIELDS, where + ".")
        if task["kind"] not in KINDS:
            raise bad(_at(where + ".kind"), task["kind"], f"use one of {list(KINDS)}")
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


REASSEMBLE_OPTIONS = {"donors": list, "partitions": list, "kind": str, "receiver_shape": str,
                      "take": (str, type(None)), "validation": int, "duration": (int, float),
                      "transient": (int, float), "preset": str, "seed": int}
DISCOVER_OPTIONS = {"genome": str, "b_min": int, "b_max": int}
REASSEMBLY_KINDS = ("homogeneous", "heterogeneous")
RUNS = ("evolve", "reoptimize")


def check_runnable(doc: dict) -> None:
    """Check every task's options (a checked document, :func:`check_document`): what its
    runner (:mod:`.work`) reads is there, of its type and value, and the tasks it reads from
    are tasks it needs, of the kind that writes what it reads. ``campaign run`` calls this
    before it writes or starts anything: a task of options made by hand fails here, in one
    line, not on a worker."""
    by_id = {t["id"]: t for t in doc["tasks"]}
    for i, task in enumerate(doc["tasks"]):
        where = f"tasks[{i}].options"
        try:
            _CHECKS[task["kind"]](where, task, by_id)
        except SomiteError as error:
            text = str(error)
            if not text.startswith(CAMPAIGN):
                text = _at(f"{where}.{text}")
            raise SomiteError(text) from None


def _kind_of(types) -> str:
    types = types if isinstance(types, tuple) else (types,)
    return " or ".join("null" if t is type(None) else t.__name__ for t in types)


def _options(where: str, options: dict, fields: dict) -> None:
    """``options`` has exactly ``fields``, each of its type (ints are not bools)."""
    for key, value in options.items():
        if key not in fields:
            raise bad(_at(f"{where}.{key}"), value, f"unknown option (use {', '.join(fields)})")
    for key, kind in fields.items():
        if key not in options:
            raise bad(_at(f"{where}.{key}"), None, "required")
        value = options[key]
        if not isinstance(value, kind) or isinstance(value, bool):
            raise bad(_at(f"{where}.{key}"), value, f"must be of type {_kind_of(kind)}")


def _needed(where: str, task: dict, value, by_id: dict, allowed: tuple[str, ...]) -> str:
    """``value`` names a task that ``task`` needs, of a kind among ``allowed``."""
    if not isinstance(value, str) or value not in task["needs"]:
        raise bad(_at(where), value, "must name a task this one needs")
    kind = by_id[value]["kind"]
    if kind not in allowed:
        article = "an" if kind[0] in "aeiou" else "a"
        raise bad(_at(where), value, f"is {article} {kind} task, not {' or '.join(allowed)}")
    return value


def _donors(where: str, task: dict, by_id: dict, count: int | None) -> None:
    donors = task["options"].get("donors")
    if not isinstance(donors, list) or not donors or (count and len(donors) != count):
        raise bad(_at(where), donors, f"a list of {count or 'the'} donor task ids")
    for donor in donors:
        _needed(where, task, donor, by_id, RUNS)


def _run(where: str, task: dict, by_id: dict) -> None:
    from ..experiments.config import resolve
    from ..sim.body import Shape

    options = task["options"]
    own = {k: v for k, v in options.items() if k not in RUN_EXTRAS}
    config = resolve(own)
    try:
        config.ga.partition(Shape.parse(config.shape))
    except SomiteError as error:
        raise bad(_at(f"{where}.modules"), config.ga.modules,
                  f"not a partition of {config.shape} ({error})") from None
    representation = "weights" if config.ga.weights_only else "graph"
    if options.get("representation", representation) != representation:
        raise bad(_at(f"{where}.representation"), options["representation"],
                  f"the options make a {representation!r} run")
    if task["kind"] == "evolve":
        for key in ("donors", "validation"):
            if key in options:
                raise bad(_at(f"{where}.{key}"), options[key],
                          "only a re-optimisation has donors and validation")
        if config.start:
            raise bad(_at(f"{where}.start"), config.start, "an evolve run starts from scratch")
        return
    from ..tasks.validation import check_count

    _needed(f"{where}.start", task, config.start, by_id, ("reassemble",))
    _donors(f"{where}.donors", task, by_id, None)
    check_count(options.get("validation"))


def _reassemble(where: str, task: dict, by_id: dict) -> None:
    from ..sim.body import Shape
    from ..sim.config import preset
    from ..tasks.validation import check_count

    options = task["options"]
    _options(where, options, REASSEMBLE_OPTIONS)
    _donors(f"{where}.donors", task, by_id, 2)
    partitions = options["partitions"]
    if not 1 <= len(partitions) <= 2 or not all(isinstance(p, str) for p in partitions):
        raise bad(_at(f"{where}.partitions"), partitions,
                  "one partition for both donors, or one per donor")
    for spec in partitions:
        if not spec.endswith(".json") or PurePosixPath(spec).is_absolute():
            continue  # a preset, a grid, or a file the campaign file named
        _inside(f"{where}.partitions", spec)
        folder, _, name = spec.rpartition("/")
        if name != "partition.json":
            raise bad(_at(f"{where}.partitions"), spec, "a file inside the campaign folder is "
                      "a discovery's partition.json")
        _needed(f"{where}.partitions", task, folder, by_id, ("discover",))
    if options["kind"] not in REASSEMBLY_KINDS:
        raise bad(_at(f"{where}.kind"), options["kind"], f"use one of {list(REASSEMBLY_KINDS)}")
    try:
        Shape.parse(options["receiver_shape"])
    except SomiteError as error:
        raise bad(_at(f"{where}.receiver_shape"), options["receiver_shape"],
                  str(error).split(": ", 1)[-1]) from None
    check_count(options["validation"])
    if not 0 <= options["seed"] < 2**32:
        raise bad(_at(f"{where}.seed"), options["seed"], "must be in [0, 2**32)")
    preset(options["preset"], duration=float(options["duration"]),
           transient=float(options["transient"]))


def _discover(where: str, task: dict, by_id: dict) -> None:
    from ..modules.discovery import check_bounds
    from ..sim.body import Shape

    options = task["options"]
    _options(where, options, DISCOVER_OPTIONS)
    genome = _needed(f"{where}.genome", task, options["genome"], by_id, RUNS)
    shape = by_id[genome]["options"].get("shape")  # checked with the genome's task
    b_min, b_max = options["b_min"], options["b_max"]
    if not isinstance(shape, str):
        if not 1 <= b_min <= b_max:
            raise bad("b_max", b_max, f"need 1 <= b_min ({b_min}) <= b_max")
        return
    try:
        check_bounds(Shape.parse(shape), b_min, b_max)
    except SomiteError as error:
        raise SomiteError(f"{error} (the shape of {genome})") from None


_CHECKS = {"evolve": _run, "reoptimize": _run, "reassemble": _reassemble,
           "discover": _discover}


def prepare(directory: str | Path, doc: dict | None, resume: bool, write: bool = True) -> dict:
    """Check ``directory`` for running ``doc`` (None: the campaign already there, with
    ``resume``) and (``write``) write ``campaign.json`` if it has none; returns the document
    to run.

    Without ``resume`` a directory must be empty (a campaign there is refused: ``--resume``
    continues it); with it, a campaign there must be this one (the same tasks)."""
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
        if there["tasks"] != doc["tasks"]:
            raise bad("out", str(directory), f"holds campaign {there.get('name')!r}, whose "
                      "tasks are not this campaign's; give another folder")
        return there
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


def finished(directory: Path, task: dict) -> bool:
    return (directory / task["path"] / DONE).is_file()


def state(directory: Path, task: dict) -> dict:
    """What the disk says of ``task``: ``state`` (done, running, partial or queued),
    ``generation`` and ``generations`` (runs), ``best`` (a run's logged best v_x so far, the
    luckiest terrain draw), ``validation`` (its mean v_x on the validation terrains where the
    last log row has it; a reassembly's v_x there) and ``done`` (its done.json, if any)."""
    folder = directory / task["path"]
    options = task["options"]
    info = {"id": task["id"], "kind": task["kind"], "state": "queued", "generation": None,
            "generations": options.get("generations"), "best": None, "validation": None,
            "done": None}
    if not folder.is_dir():
        return info
    if (folder / DONE).is_file():
        info["state"] = "done"
        try:
            info["done"] = json.loads((folder / DONE).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            pass
    elif _alive(folder / LOCK_NAME):
        info["state"] = "running"
    else:
        info["state"] = "partial"
    if task["kind"] in ("evolve", "reoptimize"):
        rows = _log_tail(folder / "log.csv")
        if rows:
            info["generation"] = int(rows[-1]["generation"])
            info["best"] = _number(rows[-1]["best_velocity"])
            info["validation"] = _number(rows[-1]["validation_velocity"])
    elif task["kind"] == "reassemble" and info["state"] == "done":
        try:
            report = json.loads((folder / "report.json").read_text(encoding="utf-8"))
            info["validation"] = report.get("validation", {}).get("v_reassembled")
        except (OSError, ValueError):
            pass
    return info


def _number(text: str) -> float | None:
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def _log_tail(path: Path) -> list[dict]:
    """The last complete row of a run's log (reading the end of the file only)."""
    try:
        with open(path, "rb") as handle:
            header = handle.readline().decode()
            size = handle.seek(0, os.SEEK_END)
            handle.seek(max(len(header), size - 4096))
            tail = handle.read().decode(errors="replace")
    except OSError:
        return []
    lines = [line for line in tail.splitlines() if line.count(",") == header.count(",")]
    if not lines:
        return []
    rows = list(csv.DictReader(io.StringIO(header + lines[-1] + "\n")))
    return rows if rows and rows[0].get("generation", "").isdigit() else []


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
