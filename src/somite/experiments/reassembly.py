"""A reassembly into a folder: what ``somite reassemble`` writes, for the command and campaigns.

``reassembled.json`` (the genome), ``report.json`` (donors, receiver, per module eta and what
the graft kept and dropped, and with validation terrains v_x of the three robots and rho) and
``report.csv`` (one row per receiver module).
"""

from __future__ import annotations

import json
from pathlib import Path

from .._io import csv_text, make_folder, write_atomic
from ..errors import bad
from ..modules.reassembly import Take, paper_takes, reassemble, receiver_for
from ..modules.transfer import transferability
from ..sim.partition import Partition
from ..tasks.validation import VALIDATION_COUNT, validation_terrains
from .origin import origin_of

CSV_COLUMNS = (
    "module",
    "donor",
    "donor_module",
    "offset_x",
    "offset_y",
    "edges_touching",
    "edges_cut",
    "eta_num",
    "eta_weight",
    "voxels_matched",
    "voxels_dropped",
    "voxels_empty",
    "nodes_kept",
    "nodes_dropped",
    "edges_kept",
    "edges_dropped",
    "hidden_pruned",
    "nodes_added",
)


def write_reassembly(out: Path, genomes, files, partitions, config, *, receiver_shape=None,
                     receiver_sensors=None, receiver_partition=None, take=None,
                     validation: int = VALIDATION_COUNT, seed: int = 0, preset: str = "paper",
                     draw: bool = False) -> dict:
    """Reassemble the two donor ``genomes`` (named ``files`` in the report) and write
    ``reassembled.json``, ``report.json`` and ``report.csv`` into ``out``; returns the
    :class:`~somite.modules.reassembly.Reassembly` and the report. The options are
    ``somite reassemble``'s; ``config`` is the SimConfig of the validation; ``draw`` names
    ``reassembled.png`` in the report, for the caller to draw."""
    donors = tuple(zip(genomes, _donor_partitions(partitions, genomes)))
    body, receiver = receiver_for(donors, receiver_shape, receiver_sensors, receiver_partition)
    takes = paper_takes(receiver, donors) if take is None else _takes(take, donors, receiver)
    result = reassemble(body, receiver, takes, donors)
    report = result.to_dict()
    for entry, path in zip(report["donors"], files):
        entry["file"] = str(path)
        # What a re-optimisation of the result trains on unless told (experiments.origin).
        entry["terrain"] = origin_of(path).terrain
    report["file"] = "reassembled.json"
    if validation:
        report["validation"] = _validation(validation, seed, preset, result.genome, genomes,
                                           config)
    if draw:
        report["draw"] = "reassembled.png"
    make_folder(out)
    result.genome.save(out / "reassembled.json")
    write_atomic(out / "report.json", json.dumps(report, indent=1, allow_nan=False) + "\n")
    write_atomic(out / "report.csv", csv_text(CSV_COLUMNS, report["modules"]))
    return result, report


def _validation(count, seed, preset, reassembled, donors, config) -> dict:
    """v_x of the new robot and both donors on the validation terrains, and rho."""
    terrains = validation_terrains(count)
    measured = transferability(reassembled, *donors, terrains, config, seed)
    return {
        "n_terrains": count, "duration": config.duration, "transient": config.transient,
        "preset": preset,
        "seed": seed, **measured.to_dict(),
    }


def _donor_partitions(specs, donors) -> tuple[Partition, Partition]:
    specs = specs or ["paper"]
    if len(specs) > 2:
        raise bad("partition", specs, "give one partition for both donors, or one per donor")
    if len(specs) == 1:
        specs = specs * 2
    return tuple(Partition.parse(s, d.body.shape) for s, d in zip(specs, donors))


def _takes(text: str, donors, receiver: Partition) -> dict[str, Take]:
    """``--take``: receiver module -> Take of ``DONOR1:MODULE`` or ``DONOR2:MODULE``."""
    takes: dict[str, Take] = {}
    for item in str(text).split(","):
        item = item.strip()
        if "=" not in item or ":" not in item.split("=", 1)[1]:
            raise bad("take", item, "expected RECEIVER_MODULE=DONOR1:MODULE or =DONOR2:MODULE")
        label, source = (part.strip() for part in item.split("=", 1))
        donor, module = (part.strip() for part in source.split(":", 1))
        number = {"donor1": 1, "1": 1, "donor2": 2, "2": 2}.get(donor.lower())
        if number is None:
            raise bad("take", item, "the donor is DONOR1 or DONOR2")
        if label not in receiver.modules:
            raise bad(
                "take", item, f"{label!r} is not a receiver module; they are {receiver.modules}"
            )
        if label in takes:
            raise bad("take", item, f"receiver module {label!r} is given twice")
        genome, partition = donors[number - 1]
        if module not in partition.modules:
            raise bad("take", item, f"donor {number} has modules {partition.modules}")
        takes[label] = Take(genome, partition, module)
    missing = [m for m in receiver.modules if m not in takes]
    if missing:
        raise bad("take", text, f"receiver modules without a donor module: {missing}")
    return takes
