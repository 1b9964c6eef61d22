"""Which experiment feeds which figure or table of ``somite report``: declared once, in the
campaign file, beside the experiment (as JGEA declares an experiment's listeners in its file).

An experiment's ``figures`` table names the figures it feeds and its group's label there::

    [experiments.mine]
    kind = "evolve"
    figures = { figure3 = "omega 1", figure5 = "topology + weights" }

A label ``""`` is the experiment's name. :data:`FIGURES` lists every figure, the kind of
experiment that feeds it and how many experiments it compares; the report draws each from the
experiments that declare it, in the campaign's order, and says in one line which figures no
experiment feeds (:func:`missing`), but for those beyond the paper (``optional``), which only
the campaigns that ask for them show. ``campaign.json`` keeps each experiment's declaration.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import bad


@dataclass(frozen=True)
class Figure:
    """A figure (or table) of the report: the kind of experiment that feeds it, what it
    shows, how many experiments it compares (None: any number), and whether it is
    ``optional``: beyond the paper, a section only where an experiment declares it (a
    campaign without it lacks nothing)."""

    kind: str
    shows: str
    groups: int | None = None
    optional: bool = False


FIGURES: dict[str, Figure] = {
    "table1": Figure("evolve", "Table 1: the paper's numbers beside this experiment's rows", 1),
    "figure3": Figure("evolve", "Figure 3: best v_x and |G| over the generations"),
    "figure5": Figure("evolve", "Figure 5: final best v_x with and without topology "
                      "optimisation (the one-sided test: is the first faster than the second)",
                      2),
    "figure10": Figure("evolve", "Figures 10 and 11: best v_x, |G| and final v_x by omega"),
    "figure7": Figure("reassemble", "Figure 7: rho during re-optimisation"),
    "figure8": Figure("reassemble", "Figures 8 and 9: rho and cut ratios of the homogeneous "
                      "reassemblies, grouped by the donors' omega (the label is not used)"),
    "discovered": Figure("reassemble", "rho along the discovered modules"),
    "edge-lengths": Figure("evolve", "the distribution of the final bests' edge lengths "
                           "(issue 72)", optional=True),
}


def parse(table, where: str, kind: str) -> dict[str, str]:
    """An experiment's ``figures`` table (``where`` names it), checked: known figures, fed by
    experiments of ``kind``, each with a label."""
    if not isinstance(table, dict):
        raise bad(where, table, "a table of figure = label (figure3 = \"omega 1\")")
    for name, label in table.items():
        if name not in FIGURES:
            raise bad(f"{where}.{name}", label, f"no such figure (use {', '.join(FIGURES)})")
        if FIGURES[name].kind != kind:
            raise bad(f"{where}.{name}", label, f"fed by {FIGURES[name].kind} experiments, "
                      f"not {kind}")
        if not isinstance(label, str):
            raise bad(f"{where}.{name}", label, "a label (a string; \"\": the experiment's name)")
    return dict(table)


def declared(experiments: dict[str, dict[str, str]]) -> dict[str, dict[str, str]]:
    """Figure -> experiment -> label (names for empty labels), in the experiments' order,
    from experiment -> its declaration."""
    out: dict[str, dict[str, str]] = {}
    for experiment, figures in experiments.items():
        for name, label in figures.items():
            out.setdefault(name, {})[experiment] = label or experiment
    return out


def check(experiments: dict[str, dict[str, str]],
          variants: dict[str, int] | None = None) -> None:
    """Refuse declarations a figure cannot draw: two groups of one label (they would merge),
    more groups than it compares (an evolve experiment of ``variants[name]`` variants is as
    many groups, ``label/variant``)."""
    variants = variants or {}
    for name, members in declared(experiments).items():
        labels = list(members.values())
        for label in labels:
            if labels.count(label) > 1:
                twice = [e for e, other in members.items() if other == label]
                raise bad(f"experiments.{twice[1]}.figures.{name}", label,
                          f"the label of {twice[0]} there too (the groups would merge)")
        limit = FIGURES[name].groups
        counted = 0
        for experiment, label in members.items():
            counted += variants.get(experiment, 1)
            if limit is not None and counted > limit:
                raise bad(f"experiments.{experiment}.figures.{name}", label,
                          f"{name} compares {limit} group(s) (an experiment's variants are a "
                          "group each): one too many")


def missing(found: dict[str, dict[str, str]],
            variants: dict[str, int] | None = None) -> dict[str, str]:
    """Figure -> why the report cannot draw it from ``found`` (:func:`declared`), an
    experiment of ``variants[name]`` variants counting as as many groups; an optional figure
    no experiment declares is not missing."""
    variants = variants or {}
    out = {}
    for name, figure in FIGURES.items():
        members = found.get(name, {})
        groups = sum(variants.get(e, 1) for e in members)
        if not members and figure.optional:
            continue
        if not members:
            out[name] = f"no {figure.kind} experiment declares it"
        elif figure.groups is not None and groups != figure.groups:
            out[name] = (f"compares {figure.groups} groups, {groups} declared "
                         f"({', '.join(members)})")
    return out
