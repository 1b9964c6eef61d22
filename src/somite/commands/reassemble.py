"""``somite reassemble``: build a robot from modules of two donors and measure what survives.

Homogeneous by default, as in the paper (:func:`somite.modules.reassembly.paper_takes`).
``--take`` says explicitly which donor module fills each receiver module, which is how a
heterogeneous reassembly (donors of other shapes) is asked for. This module parses, calls
:mod:`somite.modules.reassembly` and writes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .._io import check_output_folder
from ..errors import bad
from ..experiments.origin import origin_of
from ..experiments.reassembly import write_reassembly
from ..modules.transfer import RHO_FLOOR
from ._progress import simulating
from .common import (
    add_genome,
    add_options,
    add_simulation_options,
    check_episodes,
    load_genome,
    option,
    settings_line,
    simulation_config,
    warn,
    warn_whole_episode,
)

HELP = "Reassemble a robot from modules of two donor genomes; report eta, v_x and rho."


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
    add_simulation_options(parser, layered="donor 1's run's")
    parser.add_argument("--draw", action="store_true", help="draw the brain on the body")
    add_options(parser, "yes")


def run(args: argparse.Namespace) -> int:
    out = check_output_folder(args.out)
    if args.validation < 0:
        raise bad("validation", args.validation, "must be 0 or more")
    if args.validation:
        from ..tasks.validation import check_count

        check_count(args.validation)
    genomes = (load_genome(args.donor1), load_genome(args.donor2))
    origin = origin_of(args.donor1)
    config = simulation_config(args, origin)
    preset = option(args, "preset", origin.options())
    largest = max(genomes, key=lambda g: g.body.shape.n_voxels).body
    check_episodes(3 * args.validation, config, largest, args.yes, "this reassembly's validation")
    other = origin_of(args.donor2)
    if other.source and other.options() != origin.options():
        warn(args.prog, f"donor 2's {other.source} ran with other settings "
             f"({_settings(other)}) than donor 1's ({_settings(origin) or 'none saved'}); "
             "both donors and the new robot are measured with donor 1's")
    if args.validation:
        print(settings_line(args, config, origin, f"{args.validation} validation terrains"))
    with simulating(f"cutting the donors and measuring three robots on {args.validation} "
                    "validation terrains" if args.validation else "cutting the donors",
                    quiet=not args.validation):
        result, report = write_reassembly(
            out, genomes, (args.donor1, args.donor2), args.partition, config,
            receiver_shape=args.receiver_shape, receiver_sensors=args.receiver_sensors,
            receiver_partition=args.receiver_partition, take=args.take,
            validation=args.validation, seed=args.seed, preset=preset, draw=args.draw,
        )
    if args.draw:
        from ..viz.brain import draw_brain

        draw_brain(result.genome, out / "reassembled.png", partition=result.partition)
    _print_summary(report, out)
    if args.draw:
        print(f"  drawing -> {out / 'reassembled.png'}")
    if "validation" in report:
        _warn_weak_rho(args.prog, report["validation"])
    warn_whole_episode(args.prog, config)  # last: a caveat on the result
    return 0


def _settings(origin) -> str:
    return ", ".join(f"{key} {value:g}" if isinstance(value, float) else f"{key} {value}"
                     for key, value in origin.options().items())


def _warn_weak_rho(prog: str, validation: dict) -> None:
    donors = [validation.get("v_donor1"), validation.get("v_donor2")]
    if None in donors:
        return
    mean = (donors[0] + donors[1]) / 2
    if abs(mean) < RHO_FLOOR:
        warn(prog, f"the donors' mean v_x is {mean:.3f} m/s, below {RHO_FLOOR:g} m/s: rho "
             "divides by it and means little (the donors hardly walk)")


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
            f"reassembled {_fmt(v['v_reassembled'])} m/s  rho {_fmt(v['rho'])}"
        )


def _fmt(value) -> str:
    return "n/a" if value is None else f"{value:.3f}"
