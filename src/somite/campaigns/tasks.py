"""A campaign expanded into tasks: one per run directory, reassembly or discovery.

A task is plain data (it travels to Dask workers and into ``campaign.json``)::

    {"id": "rq1/worm-s0", "experiment": "rq1", "kind": "evolve", "path": "rq1/worm-s0",
     "needs": [...], "options": {...}}

Every option is resolved here, defaults included, so that the task list alone says what ran,
and checked here, before ``campaign.json`` is written: what a task would refuse when it runs is
refused now. Evolve and re-optimisation options are a run's ``config.json`` (plus
``representation``, and for a re-optimisation ``donors`` and ``validation``), each resolved by
:func:`~somite.experiments.config.resolve` and its ``modules`` partition parsed for its shape;
the other options name tasks by id and partitions by preset, by grid, by a discovery's
``partition.json`` relative to the campaign directory, or by the absolute path of a file the
campaign file names (:mod:`.spec`). Task ids are unique (two tasks of one id: the campaign is
refused).
"""

from __future__ import annotations

from ..errors import SomiteError, bad
from ..experiments.config import resolve
from ..sim.body import Shape
from ..sim.config import CONTROL_HZ
from ..sim.partition import Partition
from .spec import Campaign, Experiment

REOPTIMIZE_GENERATIONS = 510
"""A re-optimisation's length unless its experiment says otherwise (the paper's, and
``somite reoptimize``'s default)."""
RUN_EXTRAS = ("representation", "donors", "validation")
"""Options of an evolve or re-optimisation task that are not :class:`RunConfig` keys."""


def expand(campaign: Campaign) -> list[dict]:
    """Every task of ``campaign``, each after the tasks it needs."""
    tasks: list[dict] = []
    runs: dict[str, dict[str, dict[str, list[tuple[int, dict]]]]] = {}
    """experiment -> variant -> shape -> [(seed, evolve task)]"""
    for exp in campaign.experiments:
        if exp.kind == "evolve":
            runs[exp.name] = _evolve(campaign, exp, tasks)
        elif exp.kind == "discover":
            for groups in runs[exp.genomes].values():
                for grid in groups.values():
                    for _, run in grid:
                        tasks.append(_task(exp, _name(run), "discover", [run["id"]], {
                            "genome": run["id"], "b_min": exp.b_min, "b_max": exp.b_max}))
        else:
            _reassemble(campaign, exp, runs, tasks)
    _unique(tasks)
    return tasks


def _unique(tasks: list[dict]) -> None:
    """Refuse two tasks of one id (one would never run): the names an experiment makes of
    donor experiments, variants and shapes can meet (donors ``omega-10`` and ``omega``, whose
    variant ``10`` makes ``omega-10-worm-...`` too)."""
    seen: set[str] = set()
    for task in tasks:
        if task["id"] in seen:
            raise bad(f"experiments.{task['experiment']}", task["id"],
                      "a task id this experiment makes twice (one would never run); rename a "
                      "variant or an experiment")
        seen.add(task["id"])


def _task(exp: Experiment, name: str, kind: str, needs: list[str], options: dict) -> dict:
    task_id = f"{exp.name}/{name}"
    return {"id": task_id, "experiment": exp.name, "kind": kind, "path": task_id,
            "needs": needs, "options": options}


def _name(task: dict) -> str:
    return task["id"].split("/", 1)[1]


def _run_options(where: str, options: dict) -> dict:
    """A run's options, resolved, and its partition of ``modules`` parsed for its shape (the
    EA reads it when it starts); one-line errors name the experiment."""
    try:
        config = resolve(options)
    except SomiteError as error:
        raise SomiteError(f"{where}.{error}") from None
    try:
        config.ga.partition(Shape.parse(config.shape))
    except SomiteError as error:
        raise bad(f"{where}.modules", config.ga.modules,
                  f"not a partition of {config.shape} ({error})") from None
    data = config.to_dict()
    data["representation"] = "weights" if config.ga.weights_only else "graph"
    return data


def _evolve(campaign: Campaign, exp: Experiment, tasks: list[dict]) -> dict:
    groups: dict[str, dict[str, list]] = {}
    for variant, extra in (exp.variants or {"": {}}).items():
        grid = groups.setdefault(variant, {})
        for shape in exp.shapes:
            for seed in exp.seeds:
                where = f"experiments.{exp.name}" + (f".variants.{variant}" if variant else "")
                options = _run_options(where, {**campaign.defaults, **exp.options, **extra,
                                               "shape": shape, "seed": seed})
                prefix = f"{variant}-" if variant else ""
                task = _task(exp, f"{prefix}{shape}-s{seed}", "evolve", [], options)
                tasks.append(task)
                grid.setdefault(shape, []).append((seed, task))
    return groups


def _reassemble(campaign: Campaign, exp: Experiment, runs: dict, tasks: list[dict]) -> None:
    where = f"experiments.{exp.name}"
    made = 0
    for source in exp.donors:
        for variant, grid in runs[source].items():
            prefix = (f"{source}-" if len(exp.donors) > 1 else "") + (
                f"{variant}-" if variant else "")
            for name, first, second, receiver, take in _pairs(exp, grid, where):
                partitions = [exp.partition] * 2
                needs = [first["id"], second["id"]]
                if exp.modules_from:
                    found = f"{exp.modules_from}/{_name(first)}"
                    partitions = [f"{found}/partition.json"]
                    needs.append(found)
                run = first["options"]
                reassembly = _task(exp, prefix + name, "reassemble", needs, {
                    "donors": [first["id"], second["id"]], "partitions": partitions,
                    "kind": "homogeneous" if take is None else "heterogeneous",
                    "receiver_shape": receiver, "take": take,
                    "validation": campaign.validation, "duration": run["duration"],
                    "transient": run["transient"], "preset": run["preset"], "seed": 0})
                tasks.append(reassembly)
                made += 1
                if exp.reoptimize is None:
                    continue
                own = {k: v for k, v in run.items() if k not in RUN_EXTRAS}
                options = _run_options(where + ".reoptimize", {
                    **own, "generations": REOPTIMIZE_GENERATIONS, **exp.reoptimize,
                    "shape": receiver, "seed": run["seed"], "start": reassembly["id"]})
                options.update(donors=reassembly["options"]["donors"],
                               validation=campaign.validation)
                tasks.append(_task(exp, prefix + name + "-reopt", "reoptimize",
                                   [reassembly["id"], *needs[:2]], options))
    if not made:
        raise bad(where + ".donors", list(exp.donors), "no pair of runs to reassemble")


def _pairs(exp: Experiment, grid: dict, where: str):
    """(name, donor 1's task, donor 2's task, receiver shape, take or None) of every
    reassembly: "next" pairs run i with run i+1 of one shape (the paper's homogeneous
    reassembly), "cross" run i of one shape with run i of the other (heterogeneous)."""
    if exp.pairing == "next":
        for shape, seeded in grid.items():
            if len(seeded) < 2:
                raise bad(where + ".pairing", "next", f"needs two runs of {shape} at least")
            if not exp.modules_from:
                _modules(exp.partition, shape, where)
            for i, (seed, first) in enumerate(seeded):
                other, second = seeded[(i + 1) % len(seeded)]
                yield f"{shape}-s{seed}+s{other}", first, second, shape, None
        return
    if len(grid) != 2:
        raise bad(where + ".pairing", "cross", f"needs exactly two shapes, not {list(grid)}")
    for shape, other in (list(grid), list(grid)[::-1]):
        by_seed = dict(grid[other])
        receiver = _modules(exp.partition, shape, where)
        donor = _modules(exp.partition, other, where)
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


def run_steps(options: dict, generations: int | None = None) -> int:
    """Robot-control-steps of an evolve or re-optimisation run with ``options`` (to
    ``generations``, default all): its training episodes, validations and, for a
    re-optimisation, the transfer curve's upper bound (every best distinct) and the donors."""
    generations = options["generations"] if generations is None else generations
    steps = int(round(options["duration"] * CONTROL_HZ))
    population = options["population"]
    per_generation = population * (2 if options["reevaluate_parents"] else 1)
    training = (population + generations * per_generation) * options["evaluations"]
    every = options["validate_every"]
    validations = 0
    if every:
        validations = len({g for g in range(0, generations + 1, every)} | {generations})
    episodes = training + validations * 10
    if "donors" in options:
        episodes += (generations + 1 + len(options["donors"])) * options["validation"]
    return episodes * steps


def estimate(task: dict) -> int:
    """Robot-control-steps the task will take."""
    options = task["options"]
    if task["kind"] in ("evolve", "reoptimize"):
        return run_steps(options)
    if task["kind"] == "reassemble":
        return 3 * options["validation"] * int(round(options["duration"] * CONTROL_HZ))
    return 0
