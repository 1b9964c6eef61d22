"""``somite reassemble``: build a robot from modules of two donors and measure what survives.

Homogeneous by default, as in the paper (:func:`somite.modules.reassembly.paper_takes`).
``--take`` says explicitly which donor module fills each receiver module, which is how a
heterogeneous reassembly (donors of other shapes) is asked for. This module parses, calls
:mod:`somite.modules.reassembly` and writes.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
from pathlib import Path

from .._io import check_output_folder, write_atomic
from ..errors import bad
from ..modules.reassembly import Take, paper_takes, reassemble, receiver_for
from ..sim.partition import Partition
from .common import (
    add_genome,
    add_options,
    add_simulation_options,
    load_genome,
    simulation_config,
)

HELP = "Reassemble a robot from modules of two donor genomes; report eta, v_x and rho."

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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_genome(parser, "donor1", role="donor 1")
    add_genome(parser, "donor2", role="donor 2")
    parser.add_argument(
        "--partition", action="append", metavar="P",
        help="donors' partition: a preset (paper, worm-halves, biped-legs), a grid of labels "
        "(AAABBB/AAABBB) or a partition.json; give it twice for different donor partitions "
        "(default: paper)",
    )
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--receiver-shape", help="shape of the new robot (default: donor 1's)")
    parser.add_argument(
        "--receiver-sensors", default=None,
        help="sensor preset of the receiver (default: a donor's sensors if it has the "
        "receiver's shape, else paper)",
    )
    parser.add_argument(
        "--receiver-partition", help="partition of the receiver (default: the donor partition "
        "of the same shape, else paper)",
    )
    parser.add_argument(
        "--take", metavar="MAP",
        help="receiver module <- donor module, e.g. torso=DONOR2:front,left-leg=DONOR1:left-leg",
    )
    add_options(parser, "validation", notes={"validation": "v_x and rho on them; 0: none"})
    add_simulation_options(parser)
    parser.add_argument("--draw", action="store_true", help="draw the brain on the body")


def run(args: argparse.Namespace) -> int:
    out = _check_out(args.out)
    if args.validation < 0:
        raise bad("validation", args.validation, "must be 0 or more")
    if args.validation:
        from ..tasks.validation import check_count

        check_count(args.validation)
    config = simulation_config(args)
    genomes = (load_genome(args.donor1), load_genome(args.donor2))
    report = write_reassembly(
        out, genomes, (args.donor1, args.donor2), args.partition, config,
        receiver_shape=args.receiver_shape, receiver_sensors=args.receiver_sensors,
        receiver_partition=args.receiver_partition, take=args.take,
        validation=args.validation, seed=args.seed, preset=args.preset, draw=args.draw,
    )
    _print_summary(report, out)
    if args.draw:
        print(f"  drawing -> {out / 'reassembled.png'}")
    return 0


def write_reassembly(out: Path, genomes, files, partitions, config, *, receiver_shape=None,
                     receiver_sensors=None, receiver_partition=None, take=None,
                     validation: int = 10, seed: int = 0, preset: str = "paper",
                     draw: bool = False) -> dict:
    """Reassemble the two donor ``genomes`` (named ``files`` in the report) and write
    ``reassembled.json``, ``report.json`` and ``report.csv`` into ``out``; returns the report.
    The options are ``somite reassemble``'s; ``config`` is the SimConfig of the validation."""
    donors = tuple(zip(genomes, _donor_partitions(partitions, genomes)))
    body, receiver = receiver_for(donors, receiver_shape, receiver_sensors, receiver_partition)
    takes = paper_takes(receiver, donors) if take is None else _takes(take, donors, receiver)
    result = reassemble(body, receiver, takes, donors)
    report = result.to_dict()
    for entry, path in zip(report["donors"], files):
        entry["file"] = str(path)
    report["file"] = "reassembled.json"
    if validation:
        report["validation"] = _validation(validation, seed, preset, result.genome, genomes,
                                           config)
    if draw:
        report["draw"] = "reassembled.png"
    out.mkdir(parents=True, exist_ok=True)
    result.genome.save(out / "reassembled.json")
    write_atomic(out / "report.json", json.dumps(report, indent=1, allow_nan=False) + "\n")
    write_atomic(out / "report.csv", _csv(report["modules"]))
    if draw:
        from ..viz.brain import draw_brain

        draw_brain(result.genome, out / "reassembled.png", partition=result.partition)
    return report


def _validation(count, seed, preset, reassembled, donors, config) -> dict:
    """v_x of the new robot and both donors on the validation terrains, and rho."""
    from ..modules.transfer import transferability
    from ..tasks.validation import validation_terrains

    terrains = validation_terrains(count)
    measured = transferability(reassembled, *donors, terrains, config, seed)
    return {
        "n_terrains": count, "duration": config.duration, "preset": preset,
        "seed": seed, **measured.to_dict(),
    }


def _check_out(text: str) -> Path:
    return check_output_folder(text)


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


def _csv(rows: list[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(
        buffer, fieldnames=CSV_COLUMNS, extrasaction="ignore", lineterminator="\n"
    )
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row[k] is None else row[k]) for k in CSV_COLUMNS})
    return buffer.getvalue()


def _drawer():
    """``somite.viz.brain.draw_brain`` if it exists (it is optional here), else None."""
    try:
        from ..viz.brain import draw_brain
    except ImportError:
        return None
    return draw_brain


def _draw(draw_brain, result, path: Path) -> None:
    # draw_brain writes its file atomically itself.
    draw_brain(result.genome, path, partition=result.partition)


def _print_summary(report: dict, out: Path) -> None:
    pooled = report["pooled"]
    print(f"{report['kind']} reassembly -> {out / 'reassembled.json'}")
    for m in report["modules"]:
        print(
            f"  {m['module']:>10} <- donor {m['donor']} {m['donor_module']:<10} "
            f"eta_num {_fmt(m['eta_num'])}  eta_weight {_fmt(m['eta_weight'])}  "
            f"nodes dropped {m['nodes_dropped']}, edges dropped {m['edges_dropped']}"
        )
    print(f"  pooled eta_num {_fmt(pooled['eta_num'])}  eta_weight {_fmt(pooled['eta_weight'])}")
    if "validation" in report:
        v = report["validation"]
        print(
            f"  v_x donor1 {_fmt(v['v_donor1'])}  donor2 {_fmt(v['v_donor2'])}  "
            f"reassembled {_fmt(v['v_reassembled'])}  rho {_fmt(v['rho'])}"
        )


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.3f}"
