"""Automatic module discovery by module compactness (paper section 5.3, eq. 5).

Candidates are **all** 4-connected voxel sets whose size is in [b_min, b_max] (docs/decisions.md,
"Module discovery": the authors' partial enumeration, docs/original-system.md section 7, is a bug we
do not copy). A candidate B' is scored with the edges of the controller, each weighing |w| + |b| and
located by the voxels of its two end nodes:

- inside = total weight of the edges with both end voxels in B' (an edge within one voxel is
  inside when that voxel is in B');
- crossing = total weight of the edges with exactly one end voxel in B';
- compactness c = inside / (inside + crossing).

The most compact candidate becomes a module; the rest of the body splits into its 4-connected
components, each a module. Ranking (best first), which also breaks ties:

1. candidates with inside > 0 before those with inside = 0 (c is 0 or undefined there);
2. larger c (compared exactly, as fractions of the float sums);
3. larger inside;
4. smaller size;
5. the lexicographically smallest list of voxel positions in the body's order (bottom row
   first, left to right), i.e. the set that starts lowest and leftmost.

Sums use ``math.fsum``, so equal sets of edges give bit-equal sums whatever the order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from ..brain.genome import Genome
from ..errors import bad
from ..sim.body import Shape, component
from ..sim.partition import Partition
from .module import exact_sum

Voxel = tuple[int, int]

MAX_CANDIDATES = 1_000_000
"""Refuse enumerations larger than this (a big body with a large b_max): they would not fit."""


@dataclass(frozen=True)
class Candidate:
    """A candidate module and its score.

    Attributes
    ----------
    voxels : tuple of (x, y)
        The voxels, in the body's order.
    indices : tuple of int
        Their positions in ``shape.voxels``.
    inside, crossing : float
        Sums of |w| + |b| over the edges inside and crossing the set.
    """

    voxels: tuple[Voxel, ...]
    indices: tuple[int, ...]
    inside: float
    crossing: float

    @property
    def size(self) -> int:
        return len(self.voxels)

    @property
    def compactness(self) -> float:
        """c = inside / (inside + crossing), paper eq. 5; NaN when the set touches no edge."""
        total = self.inside + self.crossing
        return self.inside / total if total > 0 else math.nan

    def rank_key(self) -> tuple:
        """Sort key: the smallest key is the best candidate (see the module docstring)."""
        if self.inside > 0:
            c = Fraction(self.inside) / (Fraction(self.inside) + Fraction(self.crossing))
        else:
            c = Fraction(0)
        return (self.inside <= 0, -c, -self.inside, self.size, self.indices)

    def to_dict(self) -> dict:
        c = self.compactness
        return {
            "voxels": [list(v) for v in self.voxels],
            "size": self.size,
            "inside": self.inside,
            "crossing": self.crossing,
            "compactness": c if math.isfinite(c) else None,
        }


def check_bounds(shape: Shape, b_min: int, b_max: int) -> None:
    """One-line errors for sizes that make no sense for ``shape``."""
    for name, value in (("b_min", b_min), ("b_max", b_max)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise bad(name, value, "must be an integer")
    if b_min < 1:
        raise bad("b_min", b_min, "must be at least 1")
    if b_min > b_max:
        raise bad("b_min", b_min, f"must not exceed b_max={b_max}")
    if b_max > shape.n_voxels:
        raise bad("b_max", b_max, f"the body has only {shape.n_voxels} voxels")


def connected_sets(shape: Shape, b_min: int = 2, b_max: int = 5) -> tuple[tuple[int, ...], ...]:
    """Every 4-connected set of voxels with size in [b_min, b_max], as sorted voxel positions.

    Sets grow one neighbour at a time from single voxels; every connected set of size k + 1
    contains a connected set of size k (drop a leaf of a spanning tree), so all are reached.
    Ordered by size, then lexicographically.
    """
    check_bounds(shape, b_min, b_max)
    n = shape.n_voxels
    where = {v: i for i, v in enumerate(shape.voxels)}
    neighbours = [0] * n
    for i, (x, y) in enumerate(shape.voxels):
        for cell in ((x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if cell in where:
                neighbours[i] |= 1 << where[cell]
    level = {1 << i for i in range(n)}
    found: list[tuple[int, ...]] = []
    for size in range(1, b_max + 1):
        if size >= b_min:
            found.extend(sorted(_bits(mask) for mask in level))
            if len(found) > MAX_CANDIDATES:
                raise bad("b_max", b_max, f"more than {MAX_CANDIDATES} candidate sets; lower it")
        if size < b_max:
            level = _grow(level, neighbours)
    return tuple(found)


def _grow(level: set[int], neighbours: list[int]) -> set[int]:
    """All sets made of one set of ``level`` plus one voxel adjacent to it."""
    grown = set()
    for mask in level:
        frontier = 0
        for i in _bits(mask):
            frontier |= neighbours[i]
        frontier &= ~mask
        for j in _bits(frontier):
            grown.add(mask | (1 << j))
        if len(grown) > MAX_CANDIDATES:
            raise bad("b_max", len(grown), f"more than {MAX_CANDIDATES} candidate sets; lower it")
    return grown


def _bits(mask: int) -> tuple[int, ...]:
    out = []
    i = 0
    while mask:
        if mask & 1:
            out.append(i)
        mask >>= 1
        i += 1
    return tuple(out)


def score(genome: Genome, sets: tuple[tuple[int, ...], ...]) -> tuple[Candidate, ...]:
    """inside and crossing weight of each set of voxel positions, in the same order."""
    index = genome.index
    weight = np.array([e.magnitude for e in genome.edges], dtype=np.float64)
    a = index.voxel[index.src]  # (E,) voxel position of each edge's source
    b = index.voxel[index.dst]  # (E,) and of its target
    voxels = genome.body.shape.voxels
    out = []
    for members in sets:
        member = np.zeros(len(voxels), dtype=bool)
        member[list(members)] = True
        in_a, in_b = member[a], member[b]
        out.append(
            Candidate(
                tuple(voxels[i] for i in members),
                members,
                exact_sum(weight[in_a & in_b]),
                exact_sum(weight[in_a ^ in_b]),
            )
        )
    return tuple(out)


def rank_candidates(genome: Genome, b_min: int = 2, b_max: int = 5) -> tuple[Candidate, ...]:
    """Every candidate module of ``genome``'s body, scored and ranked, best first."""
    sets = connected_sets(genome.body.shape, b_min, b_max)
    return tuple(sorted(score(genome, sets), key=Candidate.rank_key))


def partition_around(shape: Shape, voxels) -> Partition:
    """``voxels`` as module ``A``; each 4-connected component of the rest as ``B``, ``C``, ...

    The other modules are lettered in the order of their first voxel in the body's order.
    """
    chosen = {tuple(v) for v in voxels}
    for cell in chosen:
        shape.index(*cell)
    label = {cell: "A" for cell in chosen}
    for cell in shape.voxels:
        if cell in label:
            continue
        name = _letter(len(set(label.values())))
        for member in component(cell, set(shape.voxels) - chosen):
            label[member] = name
    return Partition(shape, tuple(label[v] for v in shape.voxels))


def _letter(i: int) -> str:
    # One character keeps Partition.grid_string readable by Partition.from_grid.
    letters = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789"
    if i >= len(letters):
        raise bad("partition", i + 1, f"more than {len(letters)} modules")
    return letters[i]


def discover(genome: Genome, b_min: int = 2, b_max: int = 5) -> Partition:
    """Partition ``genome``'s body around its most compact module (paper section 5.3).

    The most compact candidate is module ``A``; the other modules are the 4-connected
    components of the rest of the body.
    """
    best = rank_candidates(genome, b_min, b_max)[0]
    return partition_around(genome.body.shape, best.voxels)


__all__ = [
    "Candidate",
    "check_bounds",
    "connected_sets",
    "discover",
    "partition_around",
    "rank_candidates",
    "score",
]
