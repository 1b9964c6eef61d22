"""``somite module``: export a module of a genome to a library file, or list a library."""

from __future__ import annotations

import argparse

from .._io import check_output_file, make_folder, write_atomic
from ..errors import bad
from ..experiments.lock import is_run_folder, lock_if_run
from ..experiments.origin import origin_of
from ..experiments.runner import MANIFEST, RUN_FILES
from ..modules.library import list_library, module_text, provenance_of
from ..modules.module import cut
from ..sim.partition import Partition
from .common import add_genome, add_options, finite_float, load_genome, print_json

HELP = "Module library: 'module export' writes one module of a genome, 'module list' lists."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    export = actions.add_parser(
        "export", help="write one module of a genome as a module file",
        description="Write one module of a genome (its voxels, sensors, nodes and internal "
        "edges) as a somite-module file.",
    )
    add_genome(export, role="the donor")
    export.add_argument(
        "--partition", default=None,
        help="a preset (paper, worm-halves, biped-legs), a grid of labels or a partition.json "
        "(default: the run's --modules partition when it had one, else paper)",
    )
    export.add_argument("--module", required=True, help="label of the module to export")
    export.add_argument("--out", required=True, help="module file to write (NAME.json)")
    export.add_argument(
        "--velocity", type=finite_float("velocity"), default=None,
        help="the donor's v_x [m/s], recorded in the provenance (default: the run's last "
        "validation velocity, when the donor is a run's genome)",
    )
    listing = actions.add_parser(
        "list", help="list the modules of a library folder",
        description="List the modules of a library folder (every *.json in it).",
    )
    listing.add_argument("folder", nargs="+", help="library folder(s) or module files")
    add_options(listing, "json")


def run(args: argparse.Namespace) -> int:
    if args.action == "export":
        return _export(args)
    return _list(args)


def _export(args: argparse.Namespace) -> int:
    out = check_output_file(args.out)
    if not out.name.endswith(".json") or out.name == ".json":
        raise bad("out", args.out, "a module file is named NAME.json (NAME is its library name)")
    run_files = (*RUN_FILES, MANIFEST)
    if out.name in run_files and is_run_folder(out.parent, run_files):
        raise bad("out", args.out, f"is the {out.name} of the run directory {out.parent}; "
                  "write the module elsewhere")
    # Into a run directory, only with its lock: a running run there refuses the command.
    with lock_if_run(out.parent, run_files):
        donor = load_genome(args.genome)
        if donor.delay_per_voxel:
            # A module file has no field for it: the module would run undelayed elsewhere.
            raise bad("genome", str(args.genome), f"its edges are delayed by their length "
                      f"(delay_per_voxel={donor.delay_per_voxel:g}), which a module file cannot "
                      "carry")
        origin = origin_of(args.genome)
        partition = Partition.parse(args.partition or origin.modules or "paper",
                                    donor.body.shape)
        module = cut(donor, partition).module(args.module)
        velocity = args.velocity if args.velocity is not None else origin.validation_velocity
        provenance = provenance_of(module, donor, partition.grid_string(), str(args.genome),
                                   velocity)
        if origin.source:
            given = " (given)" if args.velocity is not None else " (its last validation)"
            print(f"from {origin.source}: partition {partition.grid_string()}, v_x "
                  + ("not recorded" if velocity is None else f"{velocity:.3f} m/s{given}"))
        text = module_text(module, provenance)
        make_folder(out.parent)
        write_atomic(out, text)
    print(
        f"module {module.label!r}: {module.size} voxels, {len(module.nodes)} nodes, "
        f"{len(module.edges)} edges -> {out}"
    )
    return 0


def _list(args: argparse.Namespace) -> int:
    summaries = [item.summary() for item in list_library(args.folder)]
    if args.json:
        print_json(summaries)
        return 0
    if not summaries:
        print("no modules")
        return 0
    print(f"{'name':<20} {'size':>4} {'nodes':>5} {'edges':>5} {'v_x':>7}  sensors  (donor)")
    for s in summaries:
        sensors = " ".join(f"{kind}:{n}" for kind, n in s["sensors"].items()) or "-"
        v_x = "-" if s["v_x"] is None else f"{s['v_x']:.3f}"
        donor = f"{s['module']} of {s['donor']}" if s["donor"] else s["module"]
        print(
            f"{s['name']:<20} {s['size']:>4} {s['nodes']:>5} {s['edges']:>5} {v_x:>7}  "
            f"{sensors}  ({donor})"
        )
    return 0
