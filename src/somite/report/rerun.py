"""Every final best re-run on the fixed validation terrains, and on fresh ones under fresh
noise, cached in the report folder.

A run's logged best v_x is its luckiest terrain draw; the report puts its mean v_x on the
validation terrains (``hilly-1-10-10000``, ...: never training terrains) beside it. The episodes
are those of :meth:`somite.tasks.task.Locomotion.validate` (sensor-noise seed 0), with each
run's own episode settings, so a run that validated its last generation logged the same number.
The validation terrains are not quite unseen: a run logs its best's v_x on them and the report
picks the robots it draws by it. So each best is also re-run on fresh terrains
(:func:`~somite.tasks.validation.fresh_terrains`, ``hilly-1-10-20000``, ...: neither training
nor validation terrains) under sensor noise of another seed (:data:`FRESH_NOISE_SEED`).

The re-runs are cached in ``REPORT/cache/validation.json`` and ``fresh.json``, keyed by a hash
of the genome, the episode settings, the terrains and the noise seed: a second report on the
same campaign simulates nothing.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path

from .._io import write_atomic
from ..analysis.stats import RunLog
from ..brain.genome import Genome
from ..errors import SomiteError
from ..formats import REPORT_CACHE
from ..sim.config import SimConfig
from ..sim.terrain import Terrain
from ..tasks.validation import evaluate
from ..tasks.velocity import mean_velocity

FRESH_NOISE_SEED = 1
"""The sensor-noise seed of the fresh re-runs (the validation episodes draw seed 0)."""
FRESH_COUNT = 20
"""How many fresh terrains (:func:`somite.tasks.validation.fresh_terrains`) ``somite report``
re-runs each final best on by default."""


def cache_key(genome: Genome, sim: SimConfig, terrains: list[str], seed: int = 0) -> str:
    """What decides a re-run's numbers, hashed (somite's version included: the simulator may
    change between versions). The noise seed enters only when it is not 0, so that the keys of
    the re-runs at seed 0 stay those written before the seed was a choice."""
    import somite

    what = {"genome": genome.to_compact(), "sim": asdict(sim), "terrains": terrains,
            "somite": somite.__version__}
    if seed:
        what["seed"] = seed
    text = json.dumps(what, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def read_cache(path: Path) -> dict:
    """The cache's entries; an unreadable or foreign cache is an empty one (it is rebuilt)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return {}
    if not REPORT_CACHE.matches(data) or not isinstance(data.get("entries"), dict):
        return {}
    return data["entries"]


def write_cache(path: Path, entries: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {**REPORT_CACHE.header(), "entries": entries}
    write_atomic(path, json.dumps(data, indent=1, allow_nan=True) + "\n")


def _usable(entry, n: int) -> bool:
    return isinstance(entry, list) and len(entry) == n and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in entry)


def rerun_finals(
    runs: Mapping[str, RunLog], bests: Mapping[str, Genome], sims: Mapping[str, SimConfig],
    terrains: list[Terrain], cache: Path, seed: int = 0
) -> tuple[dict[str, dict], int]:
    """Each run's final best on ``terrains`` (the validation terrains, or fresh ones), with the
    episode settings it trained with (``sims``) and sensor-noise seed ``seed``; returns the
    results by task id and how many genomes had to be simulated (0 when the cache held them
    all).

    A result: ``velocities`` per terrain, their ``mean`` (NaN if any is NaN), the ``logged``
    final best v_x and the log's own last ``validation_velocity`` (NaN where not measured).
    """
    names = [t.name for t in terrains]
    entries = read_cache(cache)
    keys, todo = {}, {}
    for task_id in runs:
        sim = sims[task_id]
        keys[task_id] = cache_key(bests[task_id], sim, names, seed)
        if not _usable(entries.get(keys[task_id]), len(names)):
            todo.setdefault(sim, {})[keys[task_id]] = bests[task_id]
    for sim, genomes in todo.items():
        # One batch per episode setting: every genome on every terrain at once.
        velocities = evaluate(list(genomes.values()), terrains, sim, seed)
        for key, row in zip(genomes, velocities):
            entries[key] = [float(v) for v in row]
    simulated = sum(len(g) for g in todo.values())
    if simulated:
        try:
            write_cache(cache, entries)
        except OSError as error:
            raise SomiteError(f"out={str(cache.parent)!r}: cannot write the cache ({error})"
                              ) from None
    results = {}
    for task_id, run in runs.items():
        velocities = entries[keys[task_id]]
        results[task_id] = {
            "terrains": names,
            "velocities": velocities,
            "mean": float(mean_velocity(velocities)),
            "logged": run.final("best_velocity"),
            "logged_validation": run.final("validation_velocity"),
        }
    return results, simulated


__all__ = ["FRESH_COUNT", "FRESH_NOISE_SEED", "cache_key", "rerun_finals"]
