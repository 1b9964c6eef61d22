"""The title of each section of a report, by its key in ``report.json``: the heading in the
report's markdown and the title drawn on its figures. Which experiments feed a section is the
campaign's declaration (:mod:`somite.campaigns.figures`); how it is titled lives here."""

from __future__ import annotations

TITLES: dict[str, str] = {
    "table1": "Table 1: the best controller at the start and at the end",
    "figure3": "Figure 3: best v_x and |G| over the generations",
    "figure10": "Figure 10: best v_x and |G| by omega",
    "figure5": "Figure 5: final best v_x, with and without topology optimisation",
    "figure11": "Figure 11: final best v_x by omega",
    "figure7": "Figure 7: rho during re-optimisation, homogeneous and heterogeneous reassembly",
    "figure8": "Figure 8: rho during re-optimisation by omega (homogeneous reassembly)",
    "figure9": "Figure 9: edges cut by disassembly (eta) by omega",
    "rq3_reassembly": "Beyond the paper: reassembly along the discovered modules",
}

__all__ = ["TITLES"]
