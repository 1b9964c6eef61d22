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
    figures = { figure3 = "omega 1" }   # optional: the report's figures it feeds, its label
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

Each kind's own fields, checks and expansion are its entry in :mod:`.kinds`; the figures an
experiment feeds are declared in its ``figures`` table (:mod:`.figures`). Run options are
those of ``somite evolve``'s TOML (:func:`somite.experiments.config.resolve`);
they are checked when the campaign is expanded into tasks (:mod:`.expansion`), before anything
is written. A run's shape, seed and start are the campaign's to decide (``shapes``, ``seeds``, the
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
from ..errors import bad
from ..tasks.validation import VALIDATION_COUNT, check_count
from . import figures as figure_table
from .fields import CAMPAIGN_DECIDES, MAX_NAME, check_name, run_table
from .fields import typed as _typed
from .kinds import EXPERIMENT_KINDS, TASK_KINDS

COMMON = frozenset({"kind", "title", "paper", "figures"})
"""The fields of every experiment's table; each kind adds its own (:mod:`.kinds`)."""


@dataclass(frozen=True)
class Experiment:
    """One experiment of a campaign: the fields of its TOML table, checked; ``settings`` holds
    its kind's own (an evolve experiment's ``shapes``, ``seeds``, ...)."""

    name: str
    kind: str
    title: str = ""
    paper: str = ""
    figures: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


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
    title = _text(data, "title")
    validation = check_count(_typed(data, "validation", int, VALIDATION_COUNT))
    defaults = run_table(_typed(data, "defaults", dict, {}), "defaults.", CAMPAIGN_DECIDES,
                         base)
    tables = _typed(data, "experiments", dict, None)
    if not tables:
        raise bad("experiments", tables, "a campaign needs at least one experiment")
    experiments: list[Experiment] = []
    for exp_name, table in tables.items():
        experiments.append(_experiment(exp_name, table, {e.name: e for e in experiments}, base))
    figure_table.check({e.name: e.figures for e in experiments},
                       {e.name: len(e.settings.get("variants") or {}) or 1
                        for e in experiments if e.kind == "evolve"})
    return Campaign(name, source, title, validation, defaults, tuple(experiments))


MAX_TEXT = 500
"""The most characters of a title or a paper reference: they head report sections and tables."""


def _text(table: dict, key: str, where: str = "") -> str:
    text = _typed(table, key, str, "", where)
    if len(text) > MAX_TEXT:
        raise bad(where + key, text[:40] + "...", f"has {len(text)} characters; at most "
                  f"{MAX_TEXT}")
    return text


def _experiment(name: str, table, earlier: dict[str, Experiment], base: Path) -> Experiment:
    where = f"experiments.{name}."
    check_name("experiments", name)
    if not isinstance(table, dict):
        raise bad(where[:-1], table, "expected a table")
    kind = _typed(table, "kind", str, None, where)
    if kind not in EXPERIMENT_KINDS:
        raise bad(where + "kind", kind, f"use one of {list(EXPERIMENT_KINDS)}")
    known = COMMON | TASK_KINDS[kind].fields
    for key in table:
        if key not in known:
            raise bad(where + key, table[key], f"unknown field of a {kind} experiment "
                      f"({', '.join(sorted(known))})")
    figures = figure_table.parse(table.get("figures", {}), where + "figures", kind)
    return Experiment(name, kind, _text(table, "title", where), _text(table, "paper", where),
                      figures,
                      TASK_KINDS[kind].parse(table, where, earlier, base))


__all__ = ["COMMON", "Campaign", "Experiment", "MAX_NAME", "check_name", "load", "parse"]
