"""The ``reassemble`` kind: an experiment that cuts pairs of evolved bests into a reassembly
(``somite reassemble``), each optionally re-evolved by a ``reoptimize`` task."""

from __future__ import annotations

import json
from pathlib import Path, PurePosixPath

from ..._io import read_json
from ...brain.genome import Genome
from ...errors import SomiteError, bad
from ...sim.body import Shape
from ...sim.config import CONTROL_HZ, preset
from ...sim.partition import Partition
from ...tasks.validation import check_count
from ..fields import earlier, file_path, run_table, typed
from ..layout import at, inside
from .common import RUN_EXTRAS, Needs, check_options, make_task, run_options, task_name

FIELDS = frozenset({"donors", "pairing", "partition", "modules_from", "reoptimize"})
OUTPUTS = frozenset({"reassembled.json", "report.json", "report.csv"})
PAIRINGS = ("next", "cross")
REASSEMBLY_KINDS = ("homogeneous", "heterogeneous")
REOPTIMIZE_GENERATIONS = 510
"""A re-optimisation's length unless its experiment says otherwise (the paper's, and
``somite reoptimize``'s default)."""
REOPTIMIZE_DECIDES = {
    "shape": "the reassembly's receiver (one of the donors' shapes) decides the shape",
    "seed": "the seed of the first donor run (one of the donors' seeds) decides it",
    "start": "a re-optimisation starts from its reassembly",
}
"""Run options of a re-optimisation that the reassembly decides (refused, not ignored)."""
OPTIONS = {"donors": list, "partitions": list, "kind": str, "receiver_shape": str,
           "take": (str, type(None)), "validation": int, "duration": (int, float),
           "transient": (int, float), "preset": str, "seed": int}
"""A reassemble task's options, each with its type."""


def parse(table: dict, where: str, before: dict, base: Path) -> dict:
    donors = earlier(table, "donors", where, before, "evolve")
    pairing = typed(table, "pairing", str, "next", where)
    if pairing not in PAIRINGS:
        raise bad(where + "pairing", pairing, f"use one of {list(PAIRINGS)}")
    partition = file_path(typed(table, "partition", str, "paper", where), base)
    modules_from = ""
    if "modules_from" in table:
        if "partition" in table:
            raise bad(where + "modules_from", table["modules_from"],
                      "give partition or modules_from, not both")
        modules_from = earlier(table, "modules_from", where, before, "discover")[0]
        if before[modules_from].settings["genomes"] not in donors:
            raise bad(where + "modules_from", modules_from,
                      f"discovers modules of {before[modules_from].settings['genomes']}, not "
                      "of the donors")
        if pairing != "next":
            raise bad(where + "pairing", pairing, "discovered modules need pairing 'next'")
    reoptimize = None
    if "reoptimize" in table:
        reoptimize = run_table(typed(table, "reoptimize", dict, {}, where),
                               where + "reoptimize.", REOPTIMIZE_DECIDES, base)
    return {"donors": donors, "pairing": pairing, "partition": partition,
            "modules_from": modules_from, "reoptimize": reoptimize}


def expand(campaign, exp, grids: dict) -> tuple[list[dict], None]:
    """A reassembly per pair of donor runs (and its re-optimisation, if asked for)."""
    where = f"experiments.{exp.name}"
    settings = exp.settings
    tasks: list[dict] = []
    for source in settings["donors"]:
        for variant, grid in grids[source].items():
            prefix = (f"{source}-" if len(settings["donors"]) > 1 else "") + (
                f"{variant}-" if variant else "")
            for name, first, second, receiver, take in _pairs(settings, grid, where):
                partitions = [settings["partition"]] * 2
                needs = [first["id"], second["id"]]
                if settings["modules_from"]:
                    found = f"{settings['modules_from']}/{task_name(first)}"
                    partitions = [f"{found}/partition.json"]
                    needs.append(found)
                run = first["options"]
                reassembly = make_task(exp.name, prefix + name, "reassemble", needs, {
                    "donors": [first["id"], second["id"]], "partitions": partitions,
                    "kind": "homogeneous" if take is None else "heterogeneous",
                    "receiver_shape": receiver, "take": take,
                    "validation": campaign.validation, "duration": run["duration"],
                    "transient": run["transient"], "preset": run["preset"], "seed": 0})
                tasks.append(reassembly)
                if settings["reoptimize"] is None:
                    continue
                own = {k: v for k, v in run.items() if k not in RUN_EXTRAS}
                options = run_options(where + ".reoptimize", {
                    **own, "generations": REOPTIMIZE_GENERATIONS, **settings["reoptimize"],
                    "shape": receiver, "seed": run["seed"], "start": reassembly["id"]})
                options.update(donors=reassembly["options"]["donors"],
                               validation=campaign.validation)
                tasks.append(make_task(exp.name, prefix + name + "-reopt", "reoptimize",
                                       [reassembly["id"], *needs[:2]], options))
    if not tasks:
        raise bad(where + ".donors", list(settings["donors"]), "no pair of runs to reassemble")
    return tasks, None


def _pairs(settings: dict, grid: dict, where: str):
    """(name, donor 1's task, donor 2's task, receiver shape, take or None) of every
    reassembly: "next" pairs run i with run i+1 of one shape (the paper's homogeneous
    reassembly), "cross" run i of one shape with run i of the other (heterogeneous)."""
    partition = settings["partition"]
    if settings["pairing"] == "next":
        for shape, seeded in grid.items():
            if len(seeded) < 2:
                raise bad(where + ".pairing", "next", f"needs two runs of {shape} at least")
            if not settings["modules_from"]:
                _modules(partition, shape, where)
            for i, (seed, first) in enumerate(seeded):
                other, second = seeded[(i + 1) % len(seeded)]
                yield f"{shape}-s{seed}+s{other}", first, second, shape, None
        return
    if len(grid) != 2:
        raise bad(where + ".pairing", "cross", f"needs exactly two shapes, not {list(grid)}")
    for shape, other in (list(grid), list(grid)[::-1]):
        by_seed = dict(grid[other])
        receiver = _modules(partition, shape, where)
        donor = _modules(partition, other, where)
        # The paper's heterogeneous reassembly: the receiver's last module (worm front, biped
        # torso) from the other shape's last module, everything else from the receiver's run.
        take = ",".join([*(f"{m}=DONOR1:{m}" for m in receiver[:-1]),
                         f"{receiver[-1]}=DONOR2:{donor[-1]}"])
        for seed, first in grid[shape]:
            if seed in by_seed:
                yield (f"{shape}-s{seed}+{other}-s{seed}", first, by_seed[seed], shape, take)


def _modules(partition: str, shape: str, where: str) -> tuple[str, ...]:
    try:
        return Partition.parse(partition, Shape.parse(shape)).modules
    except SomiteError as error:
        raise SomiteError(f"{where}.{error}") from None


def run(root: Path, out: Path, options: dict) -> int:
    from ...experiments.reassembly import write_reassembly

    genomes = [Genome.load(root / d / "best.json") for d in options["donors"]]
    partitions = [str(root / p) if p.endswith(".json") else p for p in options["partitions"]]
    sim = preset(options["preset"], duration=options["duration"],
                 transient=options["transient"])
    write_reassembly(out, genomes, options["donors"], partitions, sim,
                     receiver_shape=options["receiver_shape"], take=options["take"],
                     validation=options["validation"], seed=options["seed"],
                     preset=options["preset"])
    return estimate(options)


def check(where: str, task: dict, needs: Needs) -> None:
    options = task["options"]
    check_options(where, options, OPTIONS)
    needs.donors(f"{where}.donors", task, 2)
    partitions = options["partitions"]
    if not 1 <= len(partitions) <= 2 or not all(isinstance(p, str) for p in partitions):
        raise bad(at(f"{where}.partitions"), partitions,
                  "one partition for both donors, or one per donor")
    for spec in partitions:
        if not spec.endswith(".json") or PurePosixPath(spec).is_absolute():
            continue  # a preset, a grid, or a file the campaign file named
        inside(f"{where}.partitions", spec)
        folder, _, name = spec.rpartition("/")
        if name != "partition.json":
            raise bad(at(f"{where}.partitions"), spec, "a file inside the campaign folder is "
                      "a discovery's partition.json")
        needs.needed(f"{where}.partitions", task, folder, "partition.json")
    if options["kind"] not in REASSEMBLY_KINDS:
        raise bad(at(f"{where}.kind"), options["kind"], f"use one of {list(REASSEMBLY_KINDS)}")
    try:
        Shape.parse(options["receiver_shape"])
    except SomiteError as error:
        raise bad(at(f"{where}.receiver_shape"), options["receiver_shape"],
                  str(error).split(": ", 1)[-1]) from None
    check_count(options["validation"])
    if not 0 <= options["seed"] < 2**32:
        raise bad(at(f"{where}.seed"), options["seed"], "must be in [0, 2**32)")
    preset(options["preset"], duration=float(options["duration"]),
           transient=float(options["transient"]))


def read(folder: Path, options: dict) -> dict:
    """The reassembly's ``report.json``."""
    report = read_json(folder / "report.json", "reassembly")
    if not isinstance(report, dict) or not isinstance(report.get("pooled"), dict):
        raise bad("reassembly", str(folder / "report.json"), "not a reassemble report")
    return {"reassembly": report}


def progress(folder: Path, options: dict, done: bool) -> dict:
    """A finished reassembly's v_x on the validation terrains."""
    if not done:
        return {}
    try:
        report = json.loads((folder / "report.json").read_text(encoding="utf-8"))
        return {"validation": report.get("validation", {}).get("v_reassembled")}
    except (OSError, ValueError, AttributeError):
        return {}


def estimate(options: dict) -> int:
    """The donors' and the reassembly's episodes on the validation terrains."""
    return 3 * options["validation"] * int(round(options["duration"] * CONTROL_HZ))


__all__ = ["FIELDS", "OUTPUTS", "PAIRINGS", "REOPTIMIZE_GENERATIONS", "check", "estimate",
           "expand", "parse", "progress", "read", "run"]
