"""``somite reassemble``: build a robot from modules of two donors and measure what survives.

Homogeneous by default (paper section 5.2.2): the receiver is donor 1's body and partition, and
donor 1 gives every module but the last one (in the partition's order) while donor 2 gives the
last one: the worm's back half from donor 1 and front half from donor 2; the biped's legs from
donor 1 and torso from donor 2. ``--take`` says explicitly which donor module fills each receiver
module, which is how a heterogeneous reassembly (donors of other shapes) is asked for.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
from pathlib import Path

from .._io import write_atomic
from ..brain.genome import Genome
from ..errors import bad
from ..modules.module import cut
from ..modules.reassembly import Take, reassemble
from ..sim.body import Body, Shape
from ..sim.partition import Partition
from .common import add_simulation_options, simulation_config

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
    parser.add_argument("donor1", help="genome file of donor 1")
    parser.add_argument("donor2", help="genome file of donor 2")
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
    parser.add_argument(
        "--validation", type=int, default=10, metavar="N",
        help="validation terrains for v_x and rho (0: do not simulate; default 10)",
    )
    add_simulation_options(parser)
    parser.add_argument("--draw", action="store_true", help="draw the brain on the body")


def run(args: argparse.Namespace) -> int:
    out = _check_out(args.out)
    if args.validation < 0:
        raise bad("validation", args.validation, "must be 0 or more")
    config = _sim_config(args)
    donors = (Genome.load(args.donor1), Genome.load(args.donor2))
    partitions = _donor_partitions(args.partition, donors)
    body, receiver = _receiver(args, donors, partitions)
    takes, which = _parts(args.take, donors, partitions, receiver)
    result = reassemble(body, receiver, takes)
    report = _report(args, donors, partitions, result, which)
    if args.validation:
        from ..modules.transfer import transferability
        from ..tasks.validation import validation_terrains

        measured = transferability(
            result.genome, *donors, validation_terrains(args.validation), config, args.seed
        )
        report["validation"] = {
            "n_terrains": args.validation, "duration": config.duration, "preset": args.preset,
            "seed": args.seed, **measured.to_dict(),
        }
    draw = _drawer() if args.draw else None
    if args.draw:
        report["draw"] = (
            "reassembled.png" if draw else "skipped: somite.viz.brain.draw_brain is not available"
        )
    out.mkdir(parents=True, exist_ok=True)
    result.genome.save(out / "reassembled.json")
    write_atomic(out / "report.json", json.dumps(report, indent=1, allow_nan=False) + "\n")
    write_atomic(out / "report.csv", _csv(report["modules"]))
    if draw:
        _draw(draw, result, out / "reassembled.png")
    _print_summary(report, out)
    if args.draw:
        print(f"  draw: {report['draw']}")
    return 0


def _check_out(text: str) -> Path:
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise bad("out", text, "exists and is not a folder")
    return out


def _sim_config(args):

    return simulation_config(args)


def _donor_partitions(specs, donors) -> tuple[Partition, Partition]:
    specs = specs or ["paper"]
    if len(specs) > 2:
        raise bad("partition", specs, "give one partition for both donors, or one per donor")
    if len(specs) == 1:
        specs = specs * 2
    return tuple(Partition.parse(s, d.body.shape) for s, d in zip(specs, donors))


def _receiver(args, donors, partitions) -> tuple[Body, Partition]:
    """The receiver body and partition: donor 1's unless told otherwise."""
    shape = Shape.parse(args.receiver_shape) if args.receiver_shape else donors[0].body.shape
    same = [i for i, d in enumerate(donors) if d.body.shape == shape]
    if args.receiver_sensors is not None:
        body = Body.build(shape, args.receiver_sensors)
    elif same:
        body = donors[same[0]].body
    else:
        body = Body.build(shape, "paper")
    if args.receiver_partition is not None:
        partition = Partition.parse(args.receiver_partition, shape)
    elif same:
        partition = partitions[same[0]]
    else:
        partition = Partition.parse("paper", shape)
    if len(partition.modules) < 2:
        raise bad("receiver-partition", partition.grid_string(), "need at least two modules")
    return body, partition


def _parts(text, donors, partitions, receiver) -> tuple[dict, dict]:
    """receiver module -> Take, and receiver module -> donor number (1 or 2)."""
    if text is None:
        return _default_parts(donors, partitions, receiver)
    which: dict[str, int] = {}
    donor_module: dict[str, str] = {}
    for item in str(text).split(","):
        item = item.strip()
        if "=" not in item or ":" not in item.split("=", 1)[1]:
            raise bad("take", item, "expected RECEIVER_MODULE=DONOR1:MODULE or =DONOR2:MODULE")
        label, source = item.split("=", 1)
        donor, module = source.split(":", 1)
        number = {"donor1": 1, "1": 1, "donor2": 2, "2": 2}.get(donor.strip().lower())
        if number is None:
            raise bad("take", item, "the donor is DONOR1 or DONOR2")
        label = label.strip()
        if label not in receiver.modules:
            raise bad(
                "take", item, f"{label!r} is not a receiver module; they are {receiver.modules}"
            )
        if label in which:
            raise bad("take", item, f"receiver module {label!r} is given twice")
        if module.strip() not in partitions[number - 1].modules:
            raise bad(
                "take", item,
                f"donor {number} has modules {partitions[number - 1].modules}",
            )
        which[label] = number
        donor_module[label] = module.strip()
    missing = [m for m in receiver.modules if m not in which]
    if missing:
        raise bad("take", text, f"receiver modules without a donor module: {missing}")
    takes = {
        m: Take(donors[which[m] - 1], partitions[which[m] - 1], donor_module[m])
        for m in receiver.modules
    }
    return takes, which


def _default_parts(donors, partitions, receiver) -> tuple[dict, dict]:
    """The paper's homogeneous reassembly: all modules but the last from donor 1."""
    for i, (donor, partition) in enumerate(zip(donors, partitions)):
        if donor.body.shape != receiver.shape or partition != receiver:
            raise bad(
                f"donor{i + 1}", donor.body.shape.grid_string(),
                "shape or partition differs from the receiver's; say which module comes from "
                "where with --take",
            )
    *first, last = receiver.modules
    which = {**{m: 1 for m in first}, last: 2}
    takes = {
        m: Take(donors[which[m] - 1], partitions[which[m] - 1], m) for m in receiver.modules
    }
    return takes, which


def _report(args, donors, partitions, result, which) -> dict:
    modules = []
    for label, take, ratio, counts in zip(
        result.partition.modules, result.takes, result.ratios, result.grafts
    ):
        counts = counts.to_dict()
        ratio = ratio.to_dict()
        modules.append({
            "module": label,
            "donor": which[label],
            "donor_module": take.label,
            "offset_x": counts["offset"][0],
            "offset_y": counts["offset"][1],
            "edges_touching": ratio["n_edges"],
            "edges_cut": ratio["n_cut"],
            "weight_touching": ratio["weight"],
            "weight_cut": ratio["weight_cut"],
            "eta_num": ratio["eta_num"],
            "eta_weight": ratio["eta_weight"],
            **{key[2:]: value for key, value in counts.items() if key.startswith("n_")},
        })
    dropped_keys = ("nodes_dropped", "edges_dropped", "hidden_pruned", "nodes_added")
    return {
        "kind": "homogeneous" if result.homogeneous else "heterogeneous",
        "donors": [
            {
                "file": str(path),
                "shape": d.body.shape.grid_string(),
                "partition": p.grid_string(),
                "nodes": d.n_nodes,
                "edges": d.n_edges,
                "cut": cut(d, p).total.to_dict(),
            }
            for path, d, p in zip((args.donor1, args.donor2), donors, partitions)
        ],
        "receiver": {
            "shape": result.genome.body.shape.grid_string(),
            "partition": result.partition.grid_string(),
            "nodes": result.genome.n_nodes,
            "edges": result.genome.n_edges,
        },
        "modules": modules,
        "pooled": result.pooled.to_dict(),
        "dropped": {key: sum(m[key] for m in modules) for key in dropped_keys},
        "file": "reassembled.json",
    }


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
