"""Run directories: an evolutionary run on disk, with checkpoints and exact resume.

A run directory holds

- ``config.json``: the resolved :class:`~somite.evolution.config.EvolutionConfig`;
- ``log.csv``: one row per generation (:data:`LOG_COLUMNS`);
- ``bests.jsonl``: the best genome of every generation, one compact JSON object a line;
- ``best.json``: the best genome so far with its body (any command that takes a genome reads it);
- ``checkpoint.json``: population, fitness, origins and generator state, written atomically
  every ``checkpoint_every`` generations and at the end.

``--resume`` cuts ``log.csv`` and ``bests.jsonl`` back to the checkpoint's generation and goes
on from there; as every random draw comes from the checkpointed generator, the resumed run
writes the same rows and the same best genome as one that was never interrupted.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._io import write_atomic
from ..brain.genome import Genome
from ..errors import bad
from ..evolution.config import EvolutionConfig, resolve
from ..evolution.ea import (
    Evaluator,
    Population,
    generation,
    initial_population,
    seeded_population,
    statistics,
)
from ..sim.body import Body
from ..sim.partition import Partition
from .logfile import LOG_COLUMNS

RUN_FILES = ("config.json", "log.csv", "bests.jsonl", "best.json", "checkpoint.json")
CHECKPOINT_FORMAT = "somite-checkpoint"
CHECKPOINT_VERSION = 1


@dataclass
class RunState:
    """Where a run stands: the parents, the generator and the bookkeeping counters."""

    generation: int
    evaluations: int
    elapsed: float
    population: Population
    rng: np.random.Generator


def _json_number(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


def save_checkpoint(path: Path, state: RunState) -> None:
    data = {
        "format": CHECKPOINT_FORMAT,
        "version": CHECKPOINT_VERSION,
        "generation": state.generation,
        "evaluations": state.evaluations,
        "elapsed_seconds": state.elapsed,
        "rng": state.rng.bit_generator.state,
        "fitness": [_json_number(f) for f in state.population.fitness],
        "origins": state.population.origins,
        "population": [json.loads(g.to_compact()) for g in state.population.genomes],
    }
    write_atomic(path, json.dumps(data, separators=(",", ":")))


def load_checkpoint(path: Path) -> RunState:
    """Read a checkpoint; anything missing or damaged is a one-line error."""
    if not path.is_file():
        raise bad("resume", str(path.parent), "no checkpoint.json in this run directory")
    try:
        data = json.loads(path.read_text())
        if data.get("format") != CHECKPOINT_FORMAT or data.get("version") != CHECKPOINT_VERSION:
            raise ValueError("unknown format or version")
        rng = np.random.default_rng()
        rng.bit_generator.state = data["rng"]
        genomes = [Genome.from_dict(g) for g in data["population"]]
        fitness = np.array([math.nan if f is None else f for f in data["fitness"]], float)
        origins = [str(o) for o in data["origins"]]
        if not (len(genomes) == len(fitness) == len(origins)) or not genomes:
            raise ValueError("population, fitness and origins differ in length")
        return RunState(
            generation=int(data["generation"]),
            evaluations=int(data["evaluations"]),
            elapsed=float(data["elapsed_seconds"]),
            population=Population(genomes, fitness, origins),
            rng=rng,
        )
    except (ValueError, KeyError, TypeError, AttributeError) as error:
        raise bad("checkpoint", str(path), f"damaged checkpoint ({error})") from None


def _log_row(state: RunState, stats: dict) -> dict:
    return {
        "generation": state.generation,
        "evaluations": state.evaluations,
        "elapsed_seconds": round(state.elapsed, 3),
        **stats,
    }


def _format(value) -> str:
    if isinstance(value, float):
        return repr(value)
    return str(value)


class RunDirectory:
    """The files of one run; appends rows as generations finish."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def file(self, name: str) -> Path:
        return self.path / name

    def has_run(self) -> bool:
        return any(self.file(name).exists() for name in RUN_FILES)

    def prepare_new(self, config: EvolutionConfig, force: bool) -> None:
        if self.path.exists() and not self.path.is_dir():
            raise bad("out", str(self.path), "exists and is not a directory")
        if self.has_run() and not force:
            raise bad("out", str(self.path), "holds a run already; use --resume or --force")
        self.path.mkdir(parents=True, exist_ok=True)
        for name in RUN_FILES:
            self.file(name).unlink(missing_ok=True)
        write_atomic(self.file("config.json"), json.dumps(config.to_dict(), indent=2) + "\n")
        write_atomic(self.file("log.csv"), ",".join(LOG_COLUMNS) + "\n")
        write_atomic(self.file("bests.jsonl"), "")

    def saved_config(self) -> EvolutionConfig:
        path = self.file("config.json")
        if not path.is_file():
            raise bad("resume", str(self.path), "no config.json in this run directory")
        try:
            return resolve(json.loads(path.read_text()))
        except json.JSONDecodeError as error:
            raise bad("config", str(path), f"not valid JSON ({error})") from None

    def cut_back(self, generation: int) -> None:
        """Drop log rows and best genomes written after ``generation`` (and torn lines)."""
        rows = []
        log = self.file("log.csv")
        if log.is_file():
            for row in csv.DictReader(io.StringIO(log.read_text())):
                try:
                    if int(row["generation"]) <= generation and None not in row.values():
                        rows.append(row)
                except (TypeError, ValueError):
                    break
        out = io.StringIO()
        writer = csv.DictWriter(out, LOG_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        write_atomic(log, out.getvalue())
        kept = []
        bests = self.file("bests.jsonl")
        if bests.is_file():
            for line in bests.read_text().splitlines():
                try:
                    if json.loads(line)["generation"] <= generation:
                        kept.append(line)
                except (ValueError, KeyError, TypeError):
                    break
        write_atomic(bests, "".join(line + "\n" for line in kept))

    def append(self, state: RunState, stats: dict) -> None:
        row = _log_row(state, stats)
        with open(self.file("log.csv"), "a", encoding="utf-8") as handle:
            handle.write(",".join(_format(row[c]) for c in LOG_COLUMNS) + "\n")
        best = state.population.genomes[state.population.best()]
        entry = {
            "generation": state.generation,
            "velocity": _json_number(stats["best_velocity"]),
            "operator": stats["best_operator"],
            "genome": json.loads(best.to_compact()),
        }
        with open(self.file("bests.jsonl"), "a", encoding="utf-8") as handle:
            handle.write(json.dumps(entry, separators=(",", ":")) + "\n")

    def save(self, state: RunState) -> None:
        best = state.population.genomes[state.population.best()]
        best.save(self.file("best.json"))
        save_checkpoint(self.file("checkpoint.json"), state)


Progress = Callable[[RunState, dict], None]


def evolve(
    config: EvolutionConfig,
    out: str | Path,
    resume: bool = False,
    force: bool = False,
    progress: Progress | None = None,
    start: Genome | None = None,
) -> RunState:
    """Run (or resume) an evolution into the run directory ``out``; returns the final state.

    With ``start`` (a re-optimisation), the first population is ``start`` and mutants of it,
    and the body is ``start``'s; otherwise the body is built from the configuration.
    ``progress`` is called after every generation with the state and the log row.
    """
    run_dir = RunDirectory(out)
    if resume:
        state = load_checkpoint(run_dir.file("checkpoint.json"))
        body = state.population.genomes[0].body
    else:
        body = start.body if start is not None else Body.build(config.shape, config.sensors)
    partition = Partition.parse(config.modules, body.shape) if config.omega != 1.0 else None
    evaluate = Evaluator(body, config)
    if resume:
        run_dir.cut_back(state.generation)
    else:
        run_dir.prepare_new(config, force)
        started = time.perf_counter()
        rng = np.random.default_rng(config.seed)
        if start is None:
            population = initial_population(body, config, evaluate, rng)
        else:
            population = seeded_population(start, config, evaluate, rng, partition,
                                           config.n_seeded_mutants())
        state = RunState(0, len(population.genomes), time.perf_counter() - started,
                         population, rng)
        _record(run_dir, state, statistics(population, population.fitness), progress)
        run_dir.save(state)
    while state.generation < config.generations:
        started = time.perf_counter()
        population, computed = generation(state.population, config, evaluate, state.rng,
                                          partition)
        state = RunState(
            state.generation + 1,
            state.evaluations + len(computed),
            state.elapsed + time.perf_counter() - started,
            population,
            state.rng,
        )
        _record(run_dir, state, statistics(population, computed), progress)
        if state.generation % config.checkpoint_every == 0 or (
            state.generation == config.generations
        ):
            run_dir.save(state)
    return state


def _record(run_dir: RunDirectory, state: RunState, stats: dict, progress: Progress | None):
    run_dir.append(state, stats)
    if progress is not None:
        progress(state, _log_row(state, stats))
