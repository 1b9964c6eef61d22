"""``somite discover``: partition a robot around its most compact module (paper eq. 5)."""

from __future__ import annotations

import argparse
import csv
import io
from pathlib import Path

from .._io import check_output_folder, write_atomic
from ..brain.genome import Genome
from ..modules.discovery import partition_around, rank_candidates, score
from .common import add_options, load_genome

HELP = "Find the most compact module of a genome (eq. 5) and partition its body around it."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_options(parser, "genome")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--min", dest="b_min", type=int, default=2, help="b_min (default 2)")
    parser.add_argument("--max", dest="b_max", type=int, default=5, help="b_max (default 5)")


def run(args: argparse.Namespace) -> int:
    out = check_output_folder(args.out)
    genome = load_genome(args.genome)
    best, partition, ranked = write_discovery(out, genome, str(args.genome), args.b_min,
                                              args.b_max)
    print(f"most compact module (c = {_fmt(best.compactness)}): {list(best.voxels)}")
    print(f"partition {partition.grid_string()} ({len(partition.modules)} modules)")
    print(f"-> {out / 'partition.json'}, {out / 'candidates.csv'} ({len(ranked)} candidates)")
    return 0


def write_discovery(out: Path, genome: Genome, name: str, b_min: int = 2, b_max: int = 5):
    """Rank the candidate modules of ``genome`` (named ``name`` in the file), partition its
    body around the most compact one and write ``partition.json`` and ``candidates.csv`` into
    ``out``; returns (best candidate, partition, ranked candidates)."""
    ranked = rank_candidates(genome, b_min, b_max)
    best = ranked[0]
    partition = partition_around(genome.body.shape, best.voxels)
    out.mkdir(parents=True, exist_ok=True)
    partition.save(
        out / "partition.json",
        genome=name,
        b_min=b_min,
        b_max=b_max,
        n_candidates=len(ranked),
        best={"label": "A", **best.to_dict()},
        scores={
            label: _module_score(genome, partition, label) for label in partition.modules
        },
    )
    write_atomic(out / "candidates.csv", _csv(ranked))
    return best, partition, ranked


def _module_score(genome: Genome, partition, label: str) -> dict:
    """inside, crossing and compactness of one module of the partition."""
    shape = genome.body.shape
    indices = tuple(shape.index(*v) for v in partition.voxels_of(label))
    [candidate] = score(genome, (indices,))
    return {k: v for k, v in candidate.to_dict().items() if k != "voxels"}


def _csv(ranked) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(("rank", "size", "voxels", "inside", "crossing", "compactness"))
    for rank, candidate in enumerate(ranked, start=1):
        voxels = " ".join(f"{x},{y}" for x, y in candidate.voxels)
        writer.writerow((
            rank, candidate.size, voxels, repr(candidate.inside), repr(candidate.crossing),
            _fmt(candidate.compactness, full=True),
        ))
    return buffer.getvalue()


def _fmt(value: float, full: bool = False) -> str:
    if value != value:  # NaN: the set touches no edge
        return "nan"
    return repr(value) if full else f"{value:.3f}"
