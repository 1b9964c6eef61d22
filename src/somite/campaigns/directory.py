"""A campaign directory: ``campaign.json``, one folder per task, and each task's state.

The layout is the contract between ``somite campaign run`` and ``somite report``: ``campaign.json``
(written before any task starts) lists the tasks in dependency order, with every option
resolved; ``<task path>/done.json``, written last, says a task is finished. Everything else in
a task's folder is what the matching command writes, and may be partial while it runs.
"""

from __future__ import annotations

import csv
import io
import json
import os
import socket
from pathlib import Path

from .._io import check_output_folder, read_json, write_atomic
from ..errors import bad
from ..experiments.lock import LOCK_NAME
from .spec import Campaign
from .work import DONE

FORMAT = "somite-campaign"
VERSION = 1
CAMPAIGN = "campaign.json"


def document(campaign: Campaign, tasks: list[dict]) -> dict:
    """The content of ``campaign.json``."""
    return {"format": FORMAT, "version": VERSION, "name": campaign.name,
            "source": campaign.source,
            "experiments": {e.name: {"title": e.title, "paper": e.paper}
                            for e in campaign.experiments},
            "tasks": tasks}


def read(directory: str | Path) -> dict:
    """``campaign.json`` of ``directory``, or a one-line error."""
    path = Path(directory) / CAMPAIGN
    if not path.is_file():
        raise bad("campaign", str(directory), "holds no campaign.json (not a campaign directory)")
    data = read_json(path, "campaign")
    if not isinstance(data, dict) or data.get("format") != FORMAT or not isinstance(
        data.get("tasks"), list
    ):
        raise bad("campaign", str(path), "not a somite campaign.json")
    if data.get("version") != VERSION:
        raise bad("campaign.version", data.get("version"), f"this somite reads {VERSION}")
    return data


def prepare(directory: str | Path, doc: dict | None, resume: bool, write: bool = True) -> dict:
    """Check ``directory`` for running ``doc`` (None: the campaign already there, with
    ``resume``) and (``write``) write ``campaign.json`` if it has none; returns the document
    to run.

    Without ``resume`` a directory must be empty (a campaign there is refused: ``--resume``
    continues it); with it, a campaign there must be this one (the same tasks)."""
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
    """Whether the lock file names a live process (one on another host is taken as live)."""
    try:
        holder = json.loads(lock.read_text(encoding="utf-8"))
        pid, host = int(holder["pid"]), holder["host"]
    except (OSError, ValueError, KeyError, TypeError):
        return False
    if host != socket.gethostname():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
