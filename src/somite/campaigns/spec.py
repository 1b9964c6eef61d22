"""Campaign files: named experiments, each a grid of runs or a stage built on earlier ones.

A campaign is TOML (or the same structure as a dict, for the built-ins)::

    title = "..."                 # optional
    validation = 10               # fixed validation terrains for v_x and rho (reassembly)
    [defaults]                    # run options of every evolve and re-optimisation
    population = 96
    [experiments.rq1]             # experiments run in file order; stages name earlier ones
    title = "..."
    paper = "Section 5.1"         # what it reproduces (the report says so)
    kind = "evolve"
    shapes = ["biped", "worm"]
    seeds = 10                    # 0..9, or a list of seeds
    options = { generations = 3000 }
    variants = { a = { omega = 10.0 }, b = { omega = 0.1 } }   # optional: a grid dimension
    [experiments.rq2-homo]
    kind = "reassemble"
    donors = "rq1"                # evolve experiment(s) whose bests are cut
    pairing = "next"              # run i + run i+1 of one shape; "cross": shape A i + shape B i
    partition = "paper"           # or modules_from = "<discover experiment>"
    reoptimize = { generations = 510 }   # optional: re-evolve every reassembled robot, with
                                         # the donors' run options and these on top
    [experiments.rq3-discovery]
    kind = "discover"
    genomes = "rq1"
    b_min = 2
    b_max = 5

Run options are those of ``somite evolve``'s TOML (:func:`somite.experiments.config.resolve`);
they are checked when the campaign is expanded into tasks (:mod:`.tasks`), before anything is
written. A run's shape, seed and start are the campaign's to decide (``shapes``, ``seeds``, the
reassembly a re-optimisation starts from): ``shape``, ``seed`` and ``start`` in ``defaults``,
``options``, a variant or ``reoptimize`` are refused, not ignored. Names (experiments,
variants) are at most :data:`MAX_NAME` characters: they become folder names.

File paths in a campaign file (a reassembly's ``partition = "parts.json"``, the ``modules``
run option) are read relative to the folder of the TOML file (for :func:`parse`, relative to
``base``, by default the current folder) and kept as absolute paths in the tasks, so that
every task reads the same file whatever folder it runs in. Everything else is checked here,
every error one line naming the field (``experiments.rq1.seeds``) and its value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .._io import read_toml
from ..errors import SomiteError, bad
from ..sim.body import Shape

KINDS = ("evolve", "reassemble", "discover")
PAIRINGS = ("next", "cross")
_NAME_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789-_.")
MAX_NAME = 64
"""Characters of an experiment's or a variant's name (a folder name, and part of task ids)."""
_RESERVED = ("campaign.json",)
"""Names a campaign directory holds already (its experiments are its top-level folders)."""
CAMPAIGN_DECIDES = {
    "shape": "the experiment's shapes decide each run's shape",
    "seed": "the experiment's seeds decide each run's seed",
    "start": "an evolve run starts from scratch, a re-optimisation from its reassembly",
}
"""Run options a campaign decides itself (refused where they would be ignored)."""
REOPTIMIZE_DECIDES = {
    "shape": "the reassembly's receiver (one of the donors' shapes) decides the shape",
    "seed": "the seed of the first donor run (one of the donors' seeds) decides it",
    "start": "a re-optimisation starts from its reassembly",
}
"""The same, for the options of a reassembly's re-optimisation."""


@dataclass(frozen=True)
class Experiment:
    """One experiment of a campaign (the fields of its TOML table, checked)."""

    name: str
    kind: str
    title: str = ""
    paper: str = ""
    shapes: tuple[str, ...] = ()
    seeds: tuple[int, ...] = ()
    options: dict = field(default_factory=dict)
    variants: dict = field(default_factory=dict)
    donors: tuple[str, ...] = ()
    pairing: str = "next"
    partition: str = "paper"
    modules_from: str = ""
    reoptimize: dict | None = None
    genomes: str = ""
    b_min: int = 2
    b_max: int = 5


@dataclass(frozen=True)
class Campaign:
    """A checked campaign: its name, where it came from, and its experiments in order."""

    name: str
    source: str
    title: str
    validation: int
    defaults: dict
    experiments: tuple[Experiment, ...]

    def experiment(self, name: str) -> Experiment:
        return next(e for e in self.experiments if e.name == name)


_KEYS = {
    "evolve": {"kind", "title", "paper", "shapes", "seeds", "options", "variants"},
    "reassemble": {"kind", "title", "paper", "donors", "pairing", "partition", "modules_from",
                   "reoptimize"},
    "discover": {"kind", "title", "paper", "genomes", "b_min", "b_max"},
}


def load(path: str | Path) -> Campaign:
    """A campaign file (TOML), checked; its file paths are read relative to its folder."""
    path = Path(path)
    data = read_toml(path, "campaign")
    return parse(data, name=path.stem, source=str(path), base=path.parent)


def parse(data: dict, name: str, source: str, base: str | Path | None = None) -> Campaign:
    """Check the campaign ``data`` (a TOML document's dict); relative file paths in it are
    read relative to ``base`` (default: the current folder) and made absolute."""
    base = Path.cwd() if base is None else Path(base)
    if not isinstance(data, dict):
        raise bad("campaign", type(data).__name__, "expected a table")
    for key in data:
        if key not in ("title", "validation", "defaults", "experiments"):
            raise bad(key, data[key], "unknown campaign field (title, validation, defaults, "
                      "experiments)")
    title = _typed(data, "title", str, "")
    validation = _typed(data, "validation", int, 10)
    if not 1 <= validation <= 1000:
        raise bad("validation", validation, "must be between 1 and 1000")
    defaults = _run_table(_typed(data, "defaults", dict, {}), "defaults.", CAMPAIGN_DECIDES,
                          base)
    tables = _typed(data, "experiments", dict, None)
    if not tables:
        raise bad("experiments", tables, "a campaign needs at least one experiment")
    experiments: list[Experiment] = []
    for exp_name, table in tables.items():
        experiments.append(_experiment(exp_name, table, {e.name: e for e in experiments}, base))
    return Campaign(name, source, title, validation, defaults, tuple(experiments))


def check_name(field: str, name: str) -> None:
    """An experiment's or a variant's name: a folder name, safe on every file system."""
    if not name or not set(name) <= _NAME_CHARS or name[0] in "-._":
        raise bad(field, name, "names use a-z, 0-9, '-', '_' and '.', and start with a letter "
                  "or digit")
    if len(name) > MAX_NAME:
        raise bad(field, name, f"names are at most {MAX_NAME} characters")
    if name in _RESERVED:
        raise bad(field, name, "is the name of the campaign directory's own file")


def _run_table(options: dict, where: str, decided: dict[str, str], base: Path) -> dict:
    """Run options of the campaign file (``where`` names them): a key the campaign decides is
    refused (it would be ignored), a partition file of ``modules`` is made absolute."""
    for key, why in decided.items():
        if key in options:
            raise bad(where + key, options[key], f"ignored in a campaign: {why}")
    options = dict(options)
    if isinstance(options.get("modules"), str):
        options["modules"] = _file(options["modules"], base)
    return options


def _file(spec: str, base: Path) -> str:
    """A partition given as a file (``*.json``) as an absolute path, relative ones read from
    ``base``; presets and grids of labels as they are."""
    if not spec.strip().endswith(".json"):
        return spec
    return str((base / spec.strip()).resolve())


def _typed(table: dict, key: str, kind: type, default, where: str = ""):
    """``table[key]`` checked to be a ``kind`` (ints are not bools), or ``default`` if absent
    (None: required)."""
    if key not in table:
        if default is None:
            raise bad(where + key, None, "required")
        return default
    value = table[key]
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise bad(where + key, value, f"must be of type {kind.__name__}")
    return value


def _experiment(name: str, table, earlier: dict[str, Experiment], base: Path) -> Experiment:
    where = f"experiments.{name}."
    check_name("experiments", name)
    if not isinstance(table, dict):
        raise bad(where[:-1], table, "expected a table")
    kind = _typed(table, "kind", str, None, where)
    if kind not in KINDS:
        raise bad(where + "kind", kind, f"use one of {list(KINDS)}")
    for key in table:
        if key not in _KEYS[kind]:
            raise bad(where + key, table[key], f"unknown field of a {kind} experiment "
                      f"({', '.join(sorted(_KEYS[kind]))})")
    common = {"name": name, "kind": kind, "title": _typed(table, "title", str, "", where),
              "paper": _typed(table, "paper", str, "", where)}
    if kind == "evolve":
        return Experiment(**common, **_grid(table, where, base))
    if kind == "discover":
        genomes = _earlier(table, "genomes", where, earlier, "evolve")[0]
        b_min = _typed(table, "b_min", int, 2, where)
        b_max = _typed(table, "b_max", int, 5, where)
        if not 1 <= b_min <= b_max:
            raise bad(where + "b_max", b_max, f"need 1 <= b_min ({b_min}) <= b_max")
        for shape in earlier[genomes].shapes:
            _candidates(shape, b_min, b_max, where)
        return Experiment(**common, genomes=genomes, b_min=b_min, b_max=b_max)
    donors = _earlier(table, "donors", where, earlier, "evolve")
    pairing = _typed(table, "pairing", str, "next", where)
    if pairing not in PAIRINGS:
        raise bad(where + "pairing", pairing, f"use one of {list(PAIRINGS)}")
    partition = _file(_typed(table, "partition", str, "paper", where), base)
    modules_from = ""
    if "modules_from" in table:
        if "partition" in table:
            raise bad(where + "modules_from", table["modules_from"],
                      "give partition or modules_from, not both")
        modules_from = _earlier(table, "modules_from", where, earlier, "discover")[0]
        if earlier[modules_from].genomes not in donors:
            raise bad(where + "modules_from", modules_from,
                      f"discovers modules of {earlier[modules_from].genomes}, not of the donors")
        if pairing != "next":
            raise bad(where + "pairing", pairing, "discovered modules need pairing 'next'")
    reoptimize = None
    if "reoptimize" in table:
        reoptimize = _run_table(_typed(table, "reoptimize", dict, {}, where),
                                where + "reoptimize.", REOPTIMIZE_DECIDES, base)
    return Experiment(**common, donors=donors, pairing=pairing, partition=partition,
                      modules_from=modules_from, reoptimize=reoptimize)


def _candidates(shape: str, b_min: int, b_max: int, where: str) -> None:
    """Refuse sizes of discovered modules that ``shape``'s body cannot have, or whose
    candidates are too many to enumerate (what the discovery itself would refuse)."""
    from ..modules.discovery import connected_sets

    try:
        connected_sets(Shape.parse(shape), b_min, b_max)
    except SomiteError as error:
        raise SomiteError(f"{where}{error} (shape {shape})") from None


def _grid(table: dict, where: str, base: Path) -> dict:
    shapes = _typed(table, "shapes", list, None, where)
    if not shapes or not all(isinstance(s, str) and s for s in shapes):
        raise bad(where + "shapes", shapes, "a non-empty list of shapes (biped, worm, ...)")
    if len(set(shapes)) != len(shapes):
        raise bad(where + "shapes", shapes, "a shape is listed twice")
    for shape in shapes:
        if shape != shape.strip():
            raise bad(where + "shapes", shape, "a shape without spaces around it")
        try:
            Shape.parse(shape)
        except SomiteError as error:
            raise SomiteError(f"{where}{error}") from None
    seeds = table.get("seeds")
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        if not 1 <= seeds <= 10_000:
            raise bad(where + "seeds", seeds, "a count from 1 to 10000, or a list of seeds")
        seeds = list(range(seeds))
    if not isinstance(seeds, list) or not seeds or not all(
        isinstance(s, int) and not isinstance(s, bool) and 0 <= s < 2**32 for s in seeds
    ):
        raise bad(where + "seeds", seeds, "a count, or a non-empty list of seeds in [0, 2**32)")
    if len(set(seeds)) != len(seeds):
        raise bad(where + "seeds", seeds, "a seed is listed twice")
    variants = _typed(table, "variants", dict, {}, where)
    for variant, options in variants.items():
        check_name(where + "variants", variant)
        if not isinstance(options, dict):
            raise bad(where + "variants." + variant, options, "expected a table of run options")
    return {"shapes": tuple(shapes), "seeds": tuple(seeds),
            "options": _run_table(_typed(table, "options", dict, {}, where), where + "options.",
                                  CAMPAIGN_DECIDES, base),
            "variants": {k: _run_table(v, f"{where}variants.{k}.", CAMPAIGN_DECIDES, base)
                         for k, v in variants.items()}}


def _earlier(table: dict, key: str, where: str, earlier: dict[str, Experiment],
             kind: str) -> tuple[str, ...]:
    """The experiment(s) ``table[key]`` names: defined before this one, of ``kind``."""
    value = table.get(key)
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise bad(where + key, value, f"name a {kind} experiment (or a list of them)")
    for name in names:
        if name not in earlier:
            raise bad(where + key, name, "no such experiment before this one")
        if earlier[name].kind != kind:
            raise bad(where + key, name, f"is a {earlier[name].kind} experiment, not {kind}")
    if len(set(names)) != len(names):
        raise bad(where + key, value, "an experiment is named twice")
    return tuple(names)
