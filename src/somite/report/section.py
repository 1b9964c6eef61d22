"""What an experiment kind adds to a report: its :class:`Section`, built from :class:`Inputs`.

Each kind of experiment (:data:`somite.campaigns.kinds.EXPERIMENT_KINDS`) has one, in its own
module of :mod:`somite.report` (``evolution``, ``reassembly``, ``discovery``), listed by kind in
:data:`.sections.SECTIONS`. The report builds every kind's section, in the kinds' order,
between its core entries (campaign, status, figures declared) and the ones every run shares
(validation, transfer, time-lapses); index.md shows them in the same order.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..viz import report_figures as figures
from .campaign import CampaignFolder
from .load import Loaded


@dataclass(frozen=True)
class Inputs:
    """What a section is built from: the campaign folder, its finished tasks as read,
    ``reruns`` (task id -> the final best re-run on the validation terrains) and the report's
    ``folder`` of figures."""

    campaign: CampaignFolder
    loaded: Loaded
    reruns: dict[str, dict]
    folder: Path

    def save(self, draw, data, stem: str, *args) -> list[str]:
        """Draw ``draw(data, *args)`` and save it as ``stem`` (PNG and SVG); nothing (no
        file) when there is nothing to draw."""
        if not data:
            return []
        return figures.save(draw(data, *args), self.folder, stem)


@dataclass(frozen=True)
class Section:
    """One kind's part of the report: ``build(inputs)`` gives its entries of report.json (key
    -> data, in the order report.json holds them; no key of another section), ``render(report)``
    the lines of index.md that show them."""

    build: Callable[[Inputs], dict]
    render: Callable[[dict], list[str]]


def add_entries(report: dict, entries: dict) -> None:
    """A section's entries, after the report's; one that would replace an entry is refused
    (two sections with one key)."""
    taken = sorted(set(entries) & set(report))
    if taken:
        raise ValueError(f"report.json's entries {taken} made by two sections")
    report.update(entries)


def joined(*parts: Section) -> Section:
    """One kind's section made of ``parts``: their entries and their lines, in order (the
    evolve experiments' figures, then the edge lengths that some of them declare). An entry
    two parts make is refused, as between kinds."""

    def build(inputs: Inputs) -> dict:
        out: dict = {}
        for part in parts:
            add_entries(out, part.build(inputs))
        return out

    return Section(build, lambda report: [line for part in parts for line in part.render(report)])


__all__ = ["Inputs", "Section", "add_entries", "joined"]
