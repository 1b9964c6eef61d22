"""What the task kinds share: a task's plain data, a run's options resolved (in one place),
the checks of a task's options against the tasks it needs, and a run's last log row."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path

from ..._io import tail_lines
from ...errors import SomiteError, bad
from ...experiments.config import RunConfig, resolve
from ..layout import at

RUN_EXTRAS = ("representation", "donors", "validation")
"""Options of an evolve or re-optimisation task that are not :class:`RunConfig` keys."""


def run_config(options: dict, where: str = "") -> RunConfig:
    """The :class:`RunConfig` of a run's task options (or of a campaign file's merged run
    options): resolved (its ``modules`` partition checked for its shape there); an error
    names ``where`` before its field. The one place a campaign resolves run options: expanding,
    checking and running a task, and reading it for the report, all come here."""
    own = {k: v for k, v in options.items() if k not in RUN_EXTRAS}
    try:
        config = resolve(own)
    except SomiteError as error:
        raise SomiteError(f"{where}{error}") from None
    return config


def representation(config: RunConfig) -> str:
    """``weights`` for a weights-only run, else ``graph``."""
    return "weights" if config.ga.weights_only else "graph"


def run_options(where: str, options: dict) -> dict:
    """A run task's options: every :class:`RunConfig` key resolved, and ``representation``."""
    config = run_config(options, f"{where}.")
    return {**config.to_dict(), "representation": representation(config)}


def make_task(experiment: str, name: str, kind: str, needs: list[str], options: dict) -> dict:
    """A task as ``campaign.json`` holds it (its path is its id)."""
    task_id = f"{experiment}/{name}"
    return {"id": task_id, "experiment": experiment, "kind": kind, "path": task_id,
            "needs": needs, "options": options}


def task_name(task: dict) -> str:
    """The task's name inside its experiment (``worm-s0``)."""
    return task["id"].split("/", 1)[1]


@dataclass(frozen=True)
class Needs:
    """The tasks of a campaign by id, and (``writes``) the files each kind's finished task
    holds: what a task's checks ask of the tasks it reads from."""

    by_id: dict[str, dict]
    writes: dict[str, frozenset[str]]

    def needed(self, where: str, task: dict, value, output: str) -> str:
        """``value`` names a task ``task`` needs, of a kind that writes ``output``."""
        if not isinstance(value, str) or value not in task["needs"]:
            raise bad(at(where), value, "must name a task this one needs")
        kind = self.by_id[value]["kind"]
        if output not in self.writes[kind]:
            article = "an" if kind[0] in "aeiou" else "a"
            makers = sorted(k for k, files in self.writes.items() if output in files)
            raise bad(at(where), value, f"is {article} {kind} task, not {' or '.join(makers)}")
        return value

    def donors(self, where: str, task: dict, count: int | None) -> None:
        """The task's ``donors``: a list (of ``count``) of needed tasks with a best genome."""
        donors = task["options"].get("donors")
        if not isinstance(donors, list) or not donors or (count and len(donors) != count):
            raise bad(at(where), donors, f"a list of {count or 'the'} donor task ids")
        for donor in donors:
            self.needed(where, task, donor, "best.json")


def _kind_of(types) -> str:
    types = types if isinstance(types, tuple) else (types,)
    return " or ".join("null" if t is type(None) else t.__name__ for t in types)


def check_options(where: str, options: dict, fields: dict) -> None:
    """``options`` has exactly ``fields``, each of its type (ints are not bools)."""
    for key, value in options.items():
        if key not in fields:
            raise bad(at(f"{where}.{key}"), value, f"unknown option (use {', '.join(fields)})")
    for key, kind in fields.items():
        if key not in options:
            raise bad(at(f"{where}.{key}"), None, "required")
        value = options[key]
        if not isinstance(value, kind) or isinstance(value, bool):
            raise bad(at(f"{where}.{key}"), value, f"must be of type {_kind_of(kind)}")


def number(text) -> float | None:
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def log_tail(path: Path, size: int = 4096) -> list[dict]:
    """The complete rows among the last ``size`` bytes of a run's log, in order (reading the
    end of the file only)."""
    try:
        with open(path, "rb") as handle:
            header = handle.readline().decode()
        lines = tail_lines(path, size, skip=len(header.encode()))
    except OSError:
        return []
    # the last line may be a row still being written
    lines = [line for line in lines if line.count(",") == header.count(",")]
    rows = list(csv.DictReader(io.StringIO(header + "".join(line + "\n" for line in lines))))
    return [row for row in rows if (row.get("generation") or "").isdigit()]
