"""Where the time of one generation goes: the kernel versus somite's Python around it.

One generation of the paper's setting (96 offspring, worm, hilly-1-10-rnd, 30 s episodes),
split into its steps, each timed with the functions `somite evolve` uses. Prints JSON.

Usage: python benchmarks/generation.py [--generations 5] [--population 96] [--shape worm]
                                      [--evolved 30]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time

import numpy as np

from somite.brain.compile import compile_genome
from somite.evolution.ea import statistics, tournament, truncate
from somite.evolution.operators import mutate
from somite.experiments.config import resolve
from somite.experiments.runner import RunDirectory, evolve
from somite.sim.system import compile_system
from somite.tasks.locomotion import compile_controllers, outcomes, run


def main() -> dict:
    parser = argparse.ArgumentParser()
    parser.add_argument("--generations", type=int, default=5)
    parser.add_argument("--population", type=int, default=96)
    parser.add_argument("--shape", default="worm")
    parser.add_argument("--evolved", type=int, default=30,
                        help="generations evolved first, so that genomes are not all minimal")
    args = parser.parse_args()
    config = resolve({"shape": args.shape, "population": args.population,
                      "generations": args.evolved})
    with tempfile.TemporaryDirectory() as folder:
        # A population that has evolved a little, so genomes are not all minimal.
        ea = evolve(config, f"{folder}/warm")
        run_dir = RunDirectory(f"{folder}/warm")
        body = ea.body
        operators = config.ga.variation()
        rng, rng_evaluation = ea.rng_variation, ea.rng_evaluation
        task = config.task()
        sim = task.sim
        times = {k: [] for k in ("select_and_mutate", "terrains", "compile_genomes",
                                 "compile_batch", "kernel", "outcomes", "merge_and_truncate",
                                 "log_and_bests")}
        population = ea.population
        for _ in range(args.generations):
            mark = time.perf_counter()

            def lap(name):
                nonlocal mark
                now = time.perf_counter()
                times[name].append(now - mark)
                mark = now

            children = []
            for _ in range(config.ga.population):
                parent = population.genomes[tournament(population.fitness, 5, rng)]
                children.append(mutate(parent, rng, operators)[0])
            lap("select_and_mutate")
            terrains = task.terrains.sample(rng_evaluation, len(children))
            seeds = rng_evaluation.integers(0, 2**32, len(children))
            lap("terrains")
            arrays = [compile_genome(g) for g in children]
            lap("compile_genomes")
            system = compile_system([body] * len(children), terrains)
            controllers = compile_controllers(arrays, [body.shape.n_voxels] * len(children))
            lap("compile_batch")
            trace = run(system, controllers, sim, seeds)
            lap("kernel")
            results = outcomes(trace, sim)
            fitness = np.array([o.velocity for o in results])
            non_finite = sum(o.non_finite > 0 for o in results)
            lap("outcomes")
            merged = np.concatenate([population.fitness, fitness])
            kept = truncate(merged, config.ga.population, rng)
            genomes = population.genomes + children
            origins = population.origins + ["mutate"] * len(children)
            population = type(population)([genomes[i] for i in kept], merged[kept],
                                          [origins[i] for i in kept])
            lap("merge_and_truncate")
            row = {"generation": 0, "evaluations": 0, "elapsed_seconds": 0.0,
                   **statistics(population, fitness), "validation_velocity": None,
                   "non_finite_episodes": non_finite}
            run_dir.append(row, population.genomes[population.best()])
            lap("log_and_bests")
    median = {k: float(np.median(v)) for k, v in times.items()}
    total = sum(median.values())
    python = total - median["kernel"]
    return {
        "benchmark": "one generation, paper setting",
        "shape": args.shape,
        "population": args.population,
        "median_size": float(np.median([g.size for g in population.genomes])),
        "seconds": {k: round(v, 4) for k, v in median.items()},
        "generation_seconds": round(total, 4),
        "python_overhead_seconds": round(python, 4),
        "python_overhead_fraction": round(python / total, 4),
    }


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
