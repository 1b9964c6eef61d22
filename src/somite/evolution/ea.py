"""The paper's evolutionary algorithm (Algorithm 1; original-system.md section 5).

Per generation: n_pop offspring, each a mutation of a parent chosen by tournament (size 5,
drawn with replacement); offspring evaluated each on its own fresh random terrain; with
``reevaluate_parents`` (the authors' code) the parents are re-simulated on new terrains and
their fitness replaced; parents and offspring merged; the n_pop best kept, ties broken at
random. NaN fitness counts as the worst.

All randomness comes from one ``numpy.random.Generator`` consumed in a fixed order, so a run is
a pure function of its configuration and seed, and a checkpoint of (population, fitness,
generator state) resumes it exactly.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..brain.compile import compile_genome
from ..brain.genome import Genome
from ..sim.body import Body
from ..sim.partition import Partition
from ..sim.system import compile_system
from ..sim.terrain import Terrain, hilly, parse_terrain
from ..tasks.locomotion import compile_controllers, outcomes, run
from .config import EvolutionConfig
from .operators import initial_genome, mutate

N_TERRAIN_SEEDS = 10000
"""Random training terrains are hilly-1-10-SEED with SEED in [0, 10000), as in the original."""


@dataclass
class Population:
    """The current parents: genomes, fitness (v_x, m/s, higher is better) and origins."""

    genomes: list[Genome]
    fitness: np.ndarray
    origins: list[str]

    def best(self) -> int:
        """Index of the fittest individual (NaN counts as the worst; first of equals)."""
        return int(np.argmax(_sortable(self.fitness)))


@functools.lru_cache(maxsize=16384)
def _training_terrain(seed: int) -> Terrain:
    # Generating a hilly profile takes ~1 ms in Python; runs revisit the 10,000 seeds often.
    return hilly(1.0, 10.0, seed)


def _sortable(fitness: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(fitness), -np.inf, fitness)


class Evaluator:
    """Simulates genomes of one body: each evaluation on its own terrain and noise seed."""

    def __init__(self, body: Body, config: EvolutionConfig) -> None:
        self.body = body
        self.sim = config.sim()
        self.random_terrain = config.terrain.endswith("-rnd")
        self.fixed = None if self.random_terrain else parse_terrain(config.terrain)

    def __call__(self, genomes: list[Genome], rng: np.random.Generator) -> np.ndarray:
        n = len(genomes)
        if self.random_terrain:
            terrains = [_training_terrain(int(s)) for s in rng.integers(0, N_TERRAIN_SEEDS, n)]
        else:
            terrains = [self.fixed] * n
        noise_seeds = rng.integers(0, 2**32, n)
        system = compile_system([self.body] * n, terrains, self.sim.start_gap)
        arrays = [compile_genome(g) for g in genomes]
        controllers = compile_controllers(arrays, [self.body.shape.n_voxels] * n)
        trace = run(system, controllers, self.sim, noise_seeds)
        return np.array([o.velocity for o in outcomes(trace, self.sim)])


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


def initial_population(
    body: Body, config: EvolutionConfig, evaluate: Evaluator, rng: np.random.Generator
) -> Population:
    genomes = [initial_genome(body, rng) for _ in range(config.population)]
    fitness = evaluate(genomes, rng)
    return Population(genomes, fitness, ["init"] * len(genomes))


def seeded_population(
    seed: Genome, config: EvolutionConfig, evaluate: Evaluator, rng: np.random.Generator,
    partition: Partition | None, mutants: int,
) -> Population:
    """``seed`` and ``mutants`` one-step mutants of it, evaluated (re-optimisation start)."""
    operators = config.operators()
    genomes = [seed]
    origins = ["seed"]
    for _ in range(mutants):
        child, name = mutate(seed, rng, operators, partition)
        genomes.append(child)
        origins.append(name)
    return Population(genomes, evaluate(genomes, rng), origins)


def generation(
    population: Population,
    config: EvolutionConfig,
    evaluate: Evaluator,
    rng: np.random.Generator,
    partition: Partition | None,
) -> tuple[Population, np.ndarray]:
    """One generation of Algorithm 1: the new parents and every fitness value computed."""
    operators = config.operators()
    children, origins = [], []
    for _ in range(config.population):
        parent = population.genomes[tournament(population.fitness, config.tournament, rng)]
        child, name = mutate(parent, rng, operators, partition)
        children.append(child)
        origins.append(name)
    child_fitness = evaluate(children, rng)
    computed = child_fitness
    parent_fitness = population.fitness
    if config.reevaluate_parents:
        parent_fitness = evaluate(population.genomes, rng)
        computed = np.concatenate([child_fitness, parent_fitness])
    genomes = population.genomes + children
    fitness = np.concatenate([parent_fitness, child_fitness])
    kept = truncate(fitness, config.population, rng)
    every_origin = population.origins + origins
    survivors = Population(
        [genomes[i] for i in kept], fitness[kept], [every_origin[i] for i in kept]
    )
    return survivors, computed


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
