"""The paper's evolutionary algorithm (Algorithm 1; docs/original-system.md section 5), ask/tell.

Per generation: n_pop offspring, each a mutation of a parent chosen by tournament (size 5,
drawn with replacement); offspring evaluated each on its own fresh random terrain; with
``reevaluate_parents`` (the authors' code, and somite's default) the parents are evaluated
again and their fitness replaced; parents and offspring merged; the n_pop best kept, ties
broken at random. NaN fitness counts as the worst.

The EA does not evaluate: :meth:`GraphEA.ask` says which genomes need a fitness and
:meth:`GraphEA.tell` takes it. Its randomness comes from two generators spawned from one
``SeedSequence(seed)``: ``rng_variation`` (initial genomes, tournaments, mutations, ties) and
``rng_evaluation`` (handed to the task: terrains and sensor noise). Changing the task, or how
many terrains it draws, leaves the mutations alone. A state of (population, fitness, both
generators) resumes a run exactly.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..brain.genome import Genome
from ..errors import bad, bad_type
from ..limits import MAX_BATCH, MAX_EVALUATIONS
from ..sim.body import Body
from ..sim.partition import Partition
from .config import GAConfig
from .operators import initial_genome, mutate


@dataclass
class Population:
    """The current parents: genomes, fitness (v_x, m/s, higher is better) and origins."""

    genomes: list[Genome]
    fitness: np.ndarray
    origins: list[str]

    def best(self) -> int:
        """Index of the fittest individual (NaN counts as the worst; first of equals)."""
        return int(np.argmax(_sortable(self.fitness)))


def _sortable(fitness: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(fitness), -np.inf, fitness)


def tournament(fitness: np.ndarray, size: int, rng: np.random.Generator) -> int:
    """Draw ``size`` individuals with replacement; a uniformly chosen one of the best wins."""
    drawn = rng.integers(0, len(fitness), size)
    scores = _sortable(fitness[drawn])
    winners = drawn[scores == scores.max()]
    return int(winners[rng.integers(0, len(winners))]) if len(winners) > 1 else int(winners[0])


def truncate(fitness: np.ndarray, keep: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of the ``keep`` best, best first; equal fitness ordered at random."""
    tie_break = rng.random(len(fitness))
    order = np.lexsort((tie_break, -_sortable(fitness)))
    return order[:keep]


def statistics(population: Population, computed: np.ndarray) -> dict:
    """The per-generation figures of ``log.csv`` (everything but bookkeeping columns);
    ``computed`` are the fitness values simulated this generation (for the NaN count)."""
    best = population.best()
    genome = population.genomes[best]
    finite = population.fitness[np.isfinite(population.fitness)]
    sizes = np.array([g.size for g in population.genomes])
    return {
        "best_velocity": float(population.fitness[best]),
        "median_velocity": float(np.median(finite)) if len(finite) else float("nan"),
        "worst_velocity": float(finite.min()) if len(finite) else float("nan"),
        "best_nodes": genome.n_nodes,
        "best_edges": genome.n_edges,
        "best_size": genome.size,
        "median_size": float(np.median(sizes)),
        "best_operator": population.origins[best],
        "nan_count": int(np.isnan(computed).sum()),
    }


def checked_fitness(fitness, n: int) -> np.ndarray:
    """``fitness`` of ``n`` genomes as a float64 array: real numbers (not strings, None,
    booleans or complex numbers), each finite or NaN. NaN is a failed episode (the worst, and
    ``null`` in a checkpoint); an infinity is no velocity a task measures (its episodes stop
    at the first non-finite state), would win every tournament and has no JSON spelling."""
    listed = checks.items("fitness", fitness, MAX_BATCH)
    if len(listed) != n:
        raise bad("fitness", f"{len(listed)} values", f"expected one per genome ({n})")
    for i, value in enumerate(listed):
        if not checks.is_real(value):
            raise bad_type(f"fitness[{i}]", value, "a real number (v_x in m/s), or NaN")
        try:
            infinite = math.isinf(value)
        except OverflowError:  # an integer past float's range
            infinite = True
        if infinite:
            raise bad(f"fitness[{i}]", value, "must be finite (NaN for a failed episode)")
    return np.array([float(v) for v in listed], dtype=np.float64)


@dataclass
class _Asked:
    genomes: list[Genome]
    origins: list[str]
    started: float


_FROM_CONFIG = object()
"""GraphEA's ``partition`` when not given: parsed from its configuration."""


class GraphEA:
    """The paper's EA over graph genomes of one body, driven by ask/tell.

    Parameters
    ----------
    body : Body
        Every genome drives this body.
    population : int
        n_pop (96 in the paper).
    seed : int
        Seeds ``SeedSequence(seed)``; its two children seed :attr:`rng_variation` and
        :attr:`rng_evaluation`.
    start : Genome, optional
        Re-optimisation: the first population is ``start`` and mutants of it instead of
        minimal random genomes. It must drive ``body``.
    config : GAConfig, optional
        The EA's configuration; keyword ``options`` (any :class:`GAConfig` or
        :class:`~somite.evolution.operators.OperatorConfig` field: ``omega=10``,
        ``reevaluate_parents=False``, ``p_add_node=0.3``, ...) go on top of it.
    partition : Partition or None, optional
        The partition of ``body`` that the biased operators use, already parsed from
        ``config``'s ``modules`` (default: parsed here).

    Attributes
    ----------
    generation : int
        The last generation told (0: the initial population; -1 before the first tell).
    log : list of dict
        One row per generation told, with the columns of ``log.csv``
        (:data:`somite.experiments.logfile.LOG_COLUMNS`); ``validation_velocity`` is None
        unless the caller sets it.
    """

    def __init__(
        self,
        body: Body,
        population: int | None = None,
        seed: int = 0,
        *,
        start: Genome | None = None,
        config: GAConfig | None = None,
        partition: Partition | None | object = _FROM_CONFIG,
        **options,
    ) -> None:
        if not isinstance(body, Body):
            raise bad("body", type(body).__name__, "expected a somite Body")
        base = (config or GAConfig()).to_dict()
        if population is not None:
            options["population"] = population
        self.config = GAConfig.from_options({**base, **options})
        if start is not None and checks.instance("start", start, Genome,
                                                 "a somite Genome").body != body:
            raise bad("shape", start.body.shape.grid_string(),
                      f"the start genome's body differs from the EA's {body.shape.grid_string()}")
        if start is not None and start.delay_per_voxel != self.config.delay_per_voxel:
            raise bad("delay_per_voxel", self.config.delay_per_voxel,
                      f"the start genome's edges are delayed by {start.delay_per_voxel:g} steps "
                      "per voxel: re-optimise it with its own")
        seed = checks.integer("seed", seed, 0, checks.SEED_END - 1)
        self.body = body
        self.start = start
        # A caller that parsed the configuration already (a run's RunSetup) hands its partition
        # over rather than have it parsed twice.
        self.partition = (self.config.partition(body.shape) if partition is _FROM_CONFIG
                          else partition)
        self.variation = self.config.variation()
        variation, evaluation = np.random.SeedSequence(int(seed)).spawn(2)
        self.rng_variation = np.random.default_rng(variation)
        self.rng_evaluation = np.random.default_rng(evaluation)
        self.population: Population | None = None
        self.generation = -1
        self.evaluations = 0
        self.elapsed = 0.0
        self.log: list[dict] = []
        self._asked: _Asked | None = None

    def __repr__(self) -> str:
        return (f"GraphEA(body={self.body.shape.grid_string()!r}, "
                f"population={self.config.population}, generation={self.generation})")

    # -- ask/tell -----------------------------------------------------------------------------

    def ask(self) -> list[Genome]:
        """The genomes whose fitness the next :meth:`tell` needs, in order.

        Generation 0: the initial population. Later: n_pop offspring, then (with
        ``reevaluate_parents``) the current parents. Asking again before telling returns the
        same genomes.
        """
        if self._asked is None:
            started = time.perf_counter()
            genomes, origins = self._offspring()
            self._asked = _Asked(genomes, origins, started)
        return list(self._asked.genomes)

    def tell(self, genomes: list[Genome], fitness, non_finite: int | None = None) -> dict:
        """Give the fitness (v_x in m/s, shape (len(genomes),), NaN for a failed episode) of
        the genomes :meth:`ask` returned (those objects, or copies equal to them, in the same
        order); selects the next parents and returns the log row.
        ``non_finite``: how many of their episodes had a non-finite step, for the log."""
        asked = self._asked
        if asked is None:
            raise bad("tell", "genomes", "nothing asked: call ask() first")
        genomes = checks.items("genomes", genomes, MAX_BATCH)
        if len(genomes) != len(asked.genomes):
            raise bad("tell", f"{len(genomes)} genomes",
                      f"the last ask() returned {len(asked.genomes)}")
        for i, (told, own) in enumerate(zip(genomes, asked.genomes)):
            # Equal, not only the same object: genomes evaluated elsewhere (a Dask worker)
            # come back as copies.
            if told is not own and told != own:
                raise bad("tell", f"genomes[{i}]",
                          "not the genome the last ask() returned at that position")
        fitness = checked_fitness(fitness, len(genomes))
        if non_finite is not None:
            # Each genome's episodes: at most the most terrains of an evaluation.
            non_finite = checks.integer("non_finite", non_finite, 0,
                                        len(genomes) * MAX_EVALUATIONS)
        self._asked = None
        if self.population is None:
            self.population = Population(list(asked.genomes), fitness, list(asked.origins))
        else:
            self.population = self._select(asked, fitness)
        self.generation += 1
        self.evaluations += len(genomes)
        self.elapsed += time.perf_counter() - asked.started
        row = {
            "generation": self.generation,
            "evaluations": self.evaluations,
            "elapsed_seconds": round(self.elapsed, 3),
            **statistics(self.population, fitness),
            "non_finite_episodes": None if non_finite is None else int(non_finite),
            "validation_velocity": None,
        }
        self.log.append(row)
        return row

    @property
    def best(self) -> Genome:
        """The fittest parent (NaN counts as the worst)."""
        if self.population is None:
            raise bad("best", None, "no generation told yet")
        return self.population.genomes[self.population.best()]

    @property
    def best_fitness(self) -> float:
        """Its fitness, v_x in m/s, as evaluated in training (see ``validation_velocity``)."""
        if self.population is None:
            return math.nan
        return float(self.population.fitness[self.population.best()])

    def _offspring(self) -> tuple[list[Genome], list[str]]:
        rng, config = self.rng_variation, self.config
        if self.population is None and self.start is None:
            genomes = [initial_genome(self.body, rng, config.delay_per_voxel)
                       for _ in range(config.population)]
            return genomes, ["init"] * config.population
        genomes, origins = ([self.start], ["seed"]) if self.population is None else ([], [])
        count = config.n_seeded_mutants() if self.population is None else config.population
        for _ in range(count):
            parent = self.start if self.population is None else self.population.genomes[
                tournament(self.population.fitness, config.tournament, rng)]
            child, name = mutate(parent, rng, self.variation, self.partition)
            genomes.append(child)
            origins.append(name)
        if self.population is not None and config.reevaluate_parents:
            genomes = genomes + self.population.genomes
        return genomes, origins

    def _select(self, asked: _Asked, fitness: np.ndarray) -> Population:
        old = self.population
        n = len(asked.origins)
        parent_fitness = fitness[n:] if self.config.reevaluate_parents else old.fitness
        genomes = old.genomes + asked.genomes[:n]
        merged = np.concatenate([parent_fitness, fitness[:n]])
        origins = old.origins + asked.origins
        kept = truncate(merged, self.config.population, self.rng_variation)
        return Population([genomes[i] for i in kept], merged[kept], [origins[i] for i in kept])

    # -- state --------------------------------------------------------------------------------

    def state(self) -> dict:
        """Everything :meth:`restore` needs, as JSON-ready data (between generations only)."""
        if self._asked is not None:
            raise bad("state", "asked", "a generation is under way: tell() it first")
        if self.population is None:
            raise bad("state", None, "no generation told yet")
        return {
            "generation": self.generation,
            "evaluations": self.evaluations,
            "elapsed_seconds": self.elapsed,
            "rng_variation": self.rng_variation.bit_generator.state,
            "rng_evaluation": self.rng_evaluation.bit_generator.state,
            "fitness": [None if math.isnan(f) else float(f) for f in self.population.fitness],
            "origins": list(self.population.origins),
            "population": [json.loads(g.to_compact()) for g in self.population.genomes],
        }

    @classmethod
    def restore(cls, state: dict, config: GAConfig | None = None,
                partition: Partition | None | object = _FROM_CONFIG) -> GraphEA:
        """The EA of :meth:`state` (its body is the genomes'); ``log`` starts empty."""
        genomes = [Genome.from_dict(g) for g in state["population"]]
        fitness = np.array([math.nan if f is None else f for f in state["fitness"]], float)
        origins = [str(o) for o in state["origins"]]
        if not (len(genomes) == len(fitness) == len(origins)) or not genomes:
            raise ValueError("population, fitness and origins differ in length")
        ea = cls(genomes[0].body, config=config, partition=partition)
        ea.rng_variation.bit_generator.state = state["rng_variation"]
        ea.rng_evaluation.bit_generator.state = state["rng_evaluation"]
        ea.population = Population(genomes, fitness, origins)
        ea.generation = int(state["generation"])
        ea.evaluations = int(state["evaluations"])
        ea.elapsed = float(state["elapsed_seconds"])
        return ea


__all__ = ["GraphEA", "Population", "statistics", "tournament", "truncate"]
