"""Each experiment kind's section of the report, by kind: the one list the report reads.

The report builds and shows them in the order of
:data:`somite.campaigns.kinds.EXPERIMENT_KINDS` (a section's build and render:
:mod:`.section`). A new kind of experiment gets its part of the report by a module of its own
here (its ``SECTION``) and its line below; a kind with nothing to show still has its line, a
:class:`~.section.Section` that builds ``{}`` and renders ``[]``. A part that only some
campaigns declare (the edge lengths, :mod:`.edge_lengths`) or that reads more of its runs
(the cuts during evolution, :mod:`.cut_curves`) joins its kind's section.
"""

from __future__ import annotations

from ..campaigns.kinds import EXPERIMENT_KINDS
from . import cut_curves, discovery, edge_lengths, evolution, reassembly
from .section import Section, joined

SECTIONS: dict[str, Section] = {
    "evolve": joined(evolution.SECTION, edge_lengths.SECTION, cut_curves.SECTION),
    "reassemble": reassembly.SECTION,  # its re-optimisations' too
    "discover": discovery.SECTION,
}
"""Experiment kind -> its section of the report."""


def in_order() -> list[Section]:
    """Every experiment kind's section, in the order of the kinds."""
    return [SECTIONS[kind] for kind in EXPERIMENT_KINDS]


def shown(report: dict) -> list[str]:
    """The kinds whose sections index.md shows: those of the campaign's experiments
    (report.json's ``campaign.kinds``; a report.json written before it lists no kinds shows
    them all). A section of a kind the campaign lacks would be empty tables."""
    kinds = report["campaign"].get("kinds")
    return list(EXPERIMENT_KINDS) if kinds is None else [k for k in EXPERIMENT_KINDS if k in kinds]


__all__ = ["SECTIONS", "in_order", "shown"]
