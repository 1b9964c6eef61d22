"""The ``discover`` kind: the modules of each evolved best of an experiment, found
automatically (``somite discover``)."""

from __future__ import annotations

from pathlib import Path

from ..._io import read_json
from ...brain.genome import Genome
from ...errors import SomiteError, bad
from ...modules.discovery import check_bounds, connected_sets
from ...sim.body import Shape
from ...sim.partition import Partition
from ..fields import earlier, typed
from .common import Needs, check_options, make_task, task_name

FIELDS = frozenset({"genomes", "b_min", "b_max"})
OUTPUTS = frozenset({"partition.json", "candidates.csv"})
OPTIONS = {"genome": str, "b_min": int, "b_max": int}


def parse(table: dict, where: str, before: dict, base: Path) -> dict:
    genomes = earlier(table, "genomes", where, before, "evolve")[0]
    b_min = typed(table, "b_min", int, 2, where)
    b_max = typed(table, "b_max", int, 5, where)
    if not 1 <= b_min <= b_max:
        raise bad(where + "b_max", b_max, f"need 1 <= b_min ({b_min}) <= b_max")
    for shape in before[genomes].settings["shapes"]:
        # Sizes the body cannot have, or too many candidates: what the discovery would refuse.
        try:
            connected_sets(Shape.parse(shape), b_min, b_max)
        except SomiteError as error:
            raise SomiteError(f"{where}{error} (shape {shape})") from None
    return {"genomes": genomes, "b_min": b_min, "b_max": b_max}


def expand(campaign, exp, grids: dict) -> tuple[list[dict], None]:
    """A discovery on every run of the experiment ``genomes`` names."""
    settings = exp.settings
    tasks = [make_task(exp.name, task_name(run), "discover", [run["id"]], {
                 "genome": run["id"], "b_min": settings["b_min"], "b_max": settings["b_max"]})
             for groups in grids[settings["genomes"]].values()
             for grid in groups.values() for _, run in grid]
    return tasks, None


def run(root: Path, out: Path, options: dict) -> int:
    from ...experiments.discovery import write_discovery

    genome = Genome.load(root / options["genome"] / "best.json")
    write_discovery(out, genome, options["genome"], options["b_min"], options["b_max"])
    return 0


def check(where: str, task: dict, needs: Needs) -> None:
    options = task["options"]
    check_options(where, options, OPTIONS)
    genome = needs.needed(f"{where}.genome", task, options["genome"], "best.json")
    shape = needs.by_id[genome]["options"].get("shape")  # checked with the genome's task
    b_min, b_max = options["b_min"], options["b_max"]
    if not isinstance(shape, str):
        if not 1 <= b_min <= b_max:
            raise bad("b_max", b_max, f"need 1 <= b_min ({b_min}) <= b_max")
        return
    try:
        check_bounds(Shape.parse(shape), b_min, b_max)
    except SomiteError as error:
        raise SomiteError(f"{error} (the shape of {genome})") from None


def read(folder: Path, options: dict) -> dict:
    """The discovered partition (``partition.json``) and its most compact module."""
    path = folder / "partition.json"
    data = read_json(path, "partition")
    partition = Partition.from_dict(data, where=str(path))
    if not isinstance(data.get("best"), dict):
        raise bad("partition", str(path), "lacks the discovered module (best)")
    return {"discovery": {**data, "partition": partition}}


def progress(folder: Path, options: dict, done: bool) -> dict:
    return {}


def estimate(options: dict) -> int:
    """No episodes: a discovery scores the genome's graph."""
    return 0


__all__ = ["FIELDS", "OUTPUTS", "check", "estimate", "expand", "parse", "progress", "read",
           "run"]
