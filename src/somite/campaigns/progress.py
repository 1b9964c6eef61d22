"""How far a campaign has got, read from its directory (the truth, whoever runs the tasks):
for the live view of ``campaign run`` and the table of ``campaign status``."""

from __future__ import annotations

import statistics
from dataclasses import dataclass, field
from pathlib import Path

from .directory import state
from .kinds import estimate


def states(directory: Path, doc: dict) -> list[dict]:
    """:func:`.directory.state` of every task, in ``campaign.json``'s order."""
    return [state(directory, t) for t in doc["tasks"]]


@dataclass
class Snapshot:
    """Counts of tasks by state, generations reached of all, robot-control-steps done of all
    (from the tasks' estimates: a running run counts the fraction of its generations it has
    logged), and the running tasks."""

    counts: dict[str, int]
    generations: tuple[int, int]
    steps: tuple[float, float]
    running: list[dict] = field(default_factory=list)

    @property
    def fraction(self) -> float:
        return self.steps[0] / max(self.steps[1], 1.0)


def _part(info: dict) -> float:
    """The share of an unfinished run's generations that its log has reached (0 for a task
    that is not a run, or has not started)."""
    if info["generation"] is None or not info["generations"]:
        return 0.0
    return min(info["generation"], info["generations"]) / info["generations"]


def snapshot(doc: dict, infos: list[dict]) -> Snapshot:
    counts = {"done": 0, "running": 0, "partial": 0, "queued": 0}
    reached = generations = 0
    done = total = 0.0
    for task, info in zip(doc["tasks"], infos):
        counts[info["state"]] += 1
        steps = estimate(task)
        total += steps
        if info["generations"] is not None:
            generations += info["generations"]
        if info["state"] == "done":
            done += steps
            reached += info["generations"] or 0
        elif info["generation"] is not None and info["generations"]:
            reached += min(info["generation"], info["generations"])
            done += steps * _part(info)
    running = [i for i in infos if i["state"] == "running"]
    return Snapshot(counts, (reached, generations), (done, total), running)


def seconds_left(doc: dict, infos: list[dict]) -> float | None:
    """Seconds of computing the campaign's unfinished tasks still need, one task at a time:
    each started run's robot-control-steps left at its own pace over its last generations
    (:func:`.kinds.evolve.progress`), every other task's at the median pace of those runs.
    None where no run has a pace yet (none has logged two timed generations).

    A run's pace is of one run beside whatever else ran then (a core each, in a campaign);
    with N runs at once on N cores the campaign ends in about this over N."""
    paces, left = [], []
    for task, info in zip(doc["tasks"], infos):
        steps = estimate(task)
        per_generation = info.get("seconds_per_generation")
        own = None
        if per_generation and info["generations"]:
            own = steps / info["generations"] / per_generation
            paces.append(own)
        if info["state"] == "done":
            continue
        left.append((steps * (1.0 - _part(info)), own))
    if not paces:
        return None
    typical = statistics.median(paces)
    return sum(steps / (own or typical) for steps, own in left)
