"""A module discovery into a folder: what ``somite discover`` writes, for the command and
campaigns: ``partition.json`` (the body partitioned around its most compact module, paper eq. 5,
with every module's score and ``tied_with_best``, how many other candidates share its
compactness) and ``candidates.csv`` (every candidate, ranked)."""

from __future__ import annotations

import itertools
from pathlib import Path

from .._io import csv_text, make_folder, write_atomic
from ..brain.genome import Genome
from ..modules.discovery import partition_around, rank_candidates, score


def write_discovery(out: Path, genome: Genome, name: str, b_min: int = 2, b_max: int = 5):
    """Rank the candidate modules of ``genome`` (named ``name`` in the file), partition its
    body around the most compact one and write ``partition.json`` and ``candidates.csv`` into
    ``out``; returns (best candidate, partition, ranked candidates)."""
    ranked = rank_candidates(genome, b_min, b_max)
    best = ranked[0]
    partition = partition_around(genome.body.shape, best.voxels)
    make_folder(out)
    partition.save(
        out / "partition.json",
        genome=name,
        b_min=b_min,
        b_max=b_max,
        n_candidates=len(ranked),
        tied_with_best=tied_with_best(ranked),
        best={"label": "A", **best.to_dict()},
        scores={
            label: _module_score(genome, partition, label) for label in partition.modules
        },
    )
    write_atomic(out / "candidates.csv", _csv(ranked))
    return best, partition, ranked


def tied_with_best(ranked) -> int:
    """How many other candidates share the best's compactness (exactly, as the ranking
    compares it; every set with nothing inside ties at 0), so that only the ranking's later
    tie-breaks (larger inside, smaller, lowest) chose the best among them."""
    key = ranked[0].rank_key()[:2]
    # Ranked best first: the tied candidates are the ones right after it.
    return sum(1 for _ in itertools.takewhile(lambda c: c.rank_key()[:2] == key, ranked[1:]))


def tie_note(tied: int) -> str:
    """What ``somite discover`` says beside the best's compactness when others share it."""
    if not tied:
        return ""
    others = "1 other candidate" if tied == 1 else f"{tied} other candidates"
    return f", tied with {others}; the first in candidates.csv order is taken"


def _module_score(genome: Genome, partition, label: str) -> dict:
    """inside, crossing and compactness of one module of the partition."""
    shape = genome.body.shape
    indices = tuple(shape.index(*v) for v in partition.voxels_of(label))
    [candidate] = score(genome, (indices,))
    return {k: v for k, v in candidate.to_dict().items() if k != "voxels"}


def _csv(ranked) -> str:
    return csv_text(("rank", "size", "voxels", "inside", "crossing", "compactness"), (
        (rank, candidate.size, " ".join(f"{x},{y}" for x, y in candidate.voxels),
         repr(candidate.inside), repr(candidate.crossing),
         format_compactness(candidate.compactness, full=True))
        for rank, candidate in enumerate(ranked, start=1)))


def format_compactness(value: float, full: bool = False) -> str:
    if value != value:  # NaN: the set touches no edge
        return "nan"
    return repr(value) if full else f"{value:.3f}"
