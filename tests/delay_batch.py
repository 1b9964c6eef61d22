"""The delayed-controller batch every backend is checked on (tests/test_edge_length.py): a worm
and a biped whose genomes have edges of many lengths, their edges delayed one control step per
voxel (issue 72), on hilly terrains for 0.1 s (6 control steps: a delay shows from step 2).

Run as ``python -m tests.delay_batch NAME OUT.npz`` it runs the batch on backend ``NAME`` and
saves its trace; the ``cuda`` backend runs so under numba-cuda's simulator, which must be
switched on before Numba is imported, hence in a process of its own (tests.backend_batch.run_elsewhere).
"""

from __future__ import annotations

import sys

import numpy as np

from somite.brain.compile import compile_genome
from somite.evolution.operators import add_edge, add_node, initial_genome
from somite.sim.body import Body
from somite.sim.config import preset
from somite.sim.terrain import hilly
from somite.tasks.locomotion import compile_batch, run

from .backend_batch import save

DURATION = 0.1
SEEDS = [5, 6]


def grown(shape: str, seed: int, delay_per_voxel: float, steps: int = 40):
    """A genome of ``shape`` grown by edge and node additions, so that its edges run between
    voxels near and far (and through hidden nodes, in cycles)."""
    rng = np.random.default_rng(seed)
    genome = initial_genome(Body.build(shape), rng, delay_per_voxel)
    for i in range(steps):
        genome = add_node(genome, rng) if i % 3 == 0 else add_edge(genome, rng)
    return genome


def genomes(delay_per_voxel: float = 1.0) -> list:
    return [grown("worm", 1, delay_per_voxel), grown("biped", 2, delay_per_voxel)]


def batch(delayed: list):
    bodies = [g.body for g in delayed]
    terrains = [hilly(1.0, 10.0, 7), hilly(1.0, 10.0, 8)]
    config = preset("paper", duration=DURATION)
    system, ctrl, seeds = compile_batch(bodies, terrains, [compile_genome(g) for g in delayed],
                                        config, SEEDS)
    return system, ctrl, config, seeds


def trace_of(name: str, delayed: list):
    system, ctrl, config, seeds = batch(delayed)
    return run(system, ctrl, config, seeds, backend=name)


def main(name: str, out: str) -> None:
    save(name, out, lambda backend: trace_of(backend, genomes())._asdict())


__all__ = ["DURATION", "SEEDS", "batch", "genomes", "grown", "trace_of"]

if __name__ == "__main__":
    main(*sys.argv[1:])
