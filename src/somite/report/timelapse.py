"""A time-lapse of each experiment's best robot (per shape), like the paper's Figure 4, with a
replay page of the same episode and a line saying what its gait is.

"Best" is the highest mean v_x on the validation terrains, not the luckiest logged draw. The
robot walks the first validation terrain with its run's episode settings. A strip and its page
are drawn again only when its robot, settings or terrain changed
(``REPORT/cache/timelapse.json``, which also keeps the gait's line, with a digest of the gait
summary's source: a line written by other rules is stale, and drawn again).

An interim report (``--under-way``) also draws each run under way's best of its last logged
generation (the last line of its ``bests.jsonl``) on the same terrain: what its gait is now.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

from .._io import tail_lines
from ..analysis import gait as gait_rules
from ..analysis.gait import analyse_gait
from ..analysis.stats import RunLog
from ..brain.genome import Genome
from ..campaigns.kinds.common import run_config
from ..errors import SomiteError
from ..tasks.validation import validation_terrains
from ..viz.replay import ReplayRun, write_replay
from ..viz.video import record_episode, write_episode
from .rerun import cache_key, read_cache, write_cache

FRAMES = 6
UNDER_WAY = "under-way-"
"""The name prefix of the strips and replay pages of runs under way."""


def best_per_experiment(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """(experiment, shape) -> the validation row of its best robot."""
    best: dict[tuple[str, str], dict] = {}
    for row in rows:
        key = (row["experiment"], row["shape"])
        if _score(row) > _score(best.get(key)):
            best[key] = row
    return best


def _score(row: dict | None) -> tuple:
    # A robot measured on the validation terrains beats one that went non-finite there.
    if row is None:
        return (-1, 0.0)
    if math.isfinite(row["validation"]):
        return (1, row["validation"])
    return (0, row["logged"] if math.isfinite(row["logged"]) else -math.inf)


def draw_strips(rows: list[dict], loaded, folder: Path, cache: Path
                ) -> tuple[list[dict], dict[str, dict], int]:
    """Draw the strips and replay pages into ``folder``; returns one entry per strip (file,
    replay page, gait, task, v_x), one per run under way (task -> file, replay page, gait,
    terrain, generation) and how many were drawn (0 when the cache had them all)."""
    drawn = read_cache(cache)
    strips, count = [], 0
    for (experiment, shape), row in best_per_experiment(rows).items():
        name = f"timelapse-{experiment}-{shape}.png".replace("/", "-")
        page = f"replay-{experiment}-{shape}.html".replace("/", "-")
        terrain = row["terrains"][0]
        gait, new = _draw(drawn, folder, (name, page), loaded.bests[row["task"]],
                          loaded.sims[row["task"]], terrain, row["task"],
                          f"{experiment}, {shape}: {row['task']}")
        count += new
        strips.append({"experiment": experiment, "shape": shape, "task": row["task"],
                       "file": name, "replay": page, "gait": gait, "terrain": terrain,
                       "validation": row["validation"], "logged": row["logged"]})
    current = {}
    for task, run in loaded.under_way.items():
        found = _best_so_far(run)
        if found is None:
            continue
        genome, sim, entry = found
        stem = task.replace("/", "-")
        name, page = f"{UNDER_WAY}{stem}.png", f"{UNDER_WAY}{stem}.html"
        terrain = validation_terrains(1)[0].name
        gait, new = _draw(drawn, folder, (name, page), genome, sim, terrain, task,
                          f"{task}, under way: its best at generation {entry['generation']}")
        count += new
        current[task] = {"file": name, "replay": page, "gait": gait, "terrain": terrain,
                         "generation": entry["generation"],
                         "logged": float(entry.get("velocity", math.nan))}
    forgotten = _remove_stale(folder, current, drawn)
    if count or forgotten:
        write_cache(cache, drawn)
    return strips, current, count


def _remove_stale(folder: Path, current: dict[str, dict], drawn: dict) -> bool:
    """Remove the strips and pages of runs no longer under way (finished, or a report no longer
    ``--under-way``), which nothing in the report names, and forget them in the cache ``drawn``;
    whether any was removed."""
    kept = {name for entry in current.values() for name in (entry["file"], entry["replay"])}
    removed = False
    for old in sorted(folder.glob(f"{UNDER_WAY}*")):
        if old.name in kept or old.suffix not in (".png", ".html"):
            continue
        old.unlink()
        for key in (old.name, f"{old.name}.gait"):
            drawn.pop(key, None)
        removed = True
    return removed


def _draw(drawn: dict, folder: Path, files: tuple[str, str], genome, sim, terrain: str,
          task: str, title: str) -> tuple[str, bool]:
    """The strip and replay page ``files`` of ``genome`` on ``terrain``, drawn unless the cache
    ``drawn`` has them; returns the gait's line and whether they were drawn."""
    from ..sim.terrain import parse_terrain

    name, page = files
    key = cache_key(genome, sim, [terrain])
    rules = _rules()
    cached = drawn.get(f"{page}.gait")
    if (drawn.get(name) == key and drawn.get(page) == key and isinstance(cached, dict)
            and cached.get("rules") == rules and isinstance(cached.get("line"), str)
            and (folder / name).is_file() and (folder / page).is_file()):
        return cached["line"], False
    recording = record_episode(genome.body, genome, parse_terrain(terrain), sim)
    write_episode(recording, folder / name, frames=FRAMES)
    gait = analyse_gait(recording).description
    write_replay([ReplayRun(recording, genome, task, gait)], folder / page, title=title)
    drawn.update({name: key, page: key, f"{page}.gait": {"rules": rules, "line": gait}})
    return gait, True


def _rules() -> str:
    """A digest of the gait summary's source (:mod:`somite.analysis.gait`)."""
    return hashlib.sha256(Path(gait_rules.__file__).read_bytes()).hexdigest()[:16]


TAIL_BYTES = 1 << 20
"""How much of the end of ``bests.jsonl`` is read for its last line (a line is a genome: some
10 kB at the paper's sizes)."""


def _best_so_far(run: RunLog):
    """(genome, episode settings, its bests.jsonl line) of the last generation a run under way
    wrote whole; None when it has none or it cannot be read."""
    try:
        for line in reversed(tail_lines(run.path / "bests.jsonl", TAIL_BYTES)):
            try:
                entry = json.loads(line)
                genome = Genome.from_dict(entry["genome"])
            except (ValueError, TypeError, KeyError, AttributeError, SomiteError):
                continue  # the line still being written
            if isinstance(entry.get("generation"), int):
                return genome, run_config(run.config).setup.sim, entry
    except (OSError, SomiteError):
        return None
    return None


__all__ = ["best_per_experiment", "draw_strips"]
