"""A time-lapse of each experiment's best robot (per shape), like the paper's Figure 4, with a
replay page of the same episode and a line saying what its gait is.

"Best" is the highest mean v_x on the validation terrains, not the luckiest logged draw. The
robot walks the first validation terrain with its run's episode settings. A strip and its page
are drawn again only when its robot, settings or terrain changed
(``REPORT/cache/timelapse.json``, which also keeps the gait's line).
"""

from __future__ import annotations

import math
from pathlib import Path

from ..analysis.gait import analyse_gait
from ..viz.replay import ReplayRun, write_replay
from ..viz.video import record_episode, write_episode
from .rerun import cache_key, read_cache, write_cache

FRAMES = 6


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


def draw_strips(rows: list[dict], loaded, folder: Path, cache: Path) -> tuple[list[dict], int]:
    """Draw the strips and replay pages into ``folder``; returns one entry per strip (file,
    replay page, gait, task, v_x) and how many were drawn (0 when the cache had them all)."""
    from ..sim.terrain import parse_terrain

    drawn = read_cache(cache)
    strips, count = [], 0
    for (experiment, shape), row in best_per_experiment(rows).items():
        genome = loaded.bests[row["task"]]
        sim = loaded.sims[row["task"]]
        terrain = row["terrains"][0]
        name = f"timelapse-{experiment}-{shape}.png".replace("/", "-")
        page = f"replay-{experiment}-{shape}.html".replace("/", "-")
        key = cache_key(genome, sim, [terrain])
        path = folder / name
        gait = drawn.get(f"{page}.gait")
        if (drawn.get(name) != key or drawn.get(page) != key or not isinstance(gait, str)
                or not path.is_file() or not (folder / page).is_file()):
            recording = record_episode(genome.body, genome, parse_terrain(terrain), sim)
            write_episode(recording, path, frames=FRAMES)
            gait = analyse_gait(recording).description
            write_replay([ReplayRun(recording, genome, row["task"], gait)], folder / page,
                         title=f"{experiment}, {shape}: {row['task']}")
            drawn.update({name: key, page: key, f"{page}.gait": gait})
            count += 1
        strips.append({"experiment": experiment, "shape": shape, "task": row["task"],
                       "file": name, "replay": page, "gait": gait, "terrain": terrain,
                       "validation": row["validation"], "logged": row["logged"]})
    if count:
        write_cache(cache, drawn)
    return strips, count


__all__ = ["best_per_experiment", "draw_strips"]
