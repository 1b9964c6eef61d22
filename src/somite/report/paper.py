"""The numbers the paper reports (Pigozzi & Medvet), each with where it comes from.

The report prints these beside the campaign's own numbers. Where the paper gives only a claim or
a rough figure read off a plot ("hover above 60 %"), ``value`` is that rough number and ``text``
quotes the claim; ``value`` is None where the paper gives no number at all. Section numbers are
the paper's.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Reported:
    """One reported number: ``value`` (+/- ``sd`` where given), the claim and its place."""

    value: float | None
    where: str
    text: str = ""
    sd: float | None = None

    def to_dict(self) -> dict:
        return asdict(self)

    def show(self) -> str:
        """As printed in a table cell: ``88.5 ± 17.3``, ``≈ 5``, or the claim."""
        if self.value is None:
            return self.text
        if self.sd is not None:
            return f"{self.value:g} ± {self.sd:g}"
        return f"{self.value:g}" if not self.text.startswith("≈") else f"≈ {self.value:g}"


_TABLE1 = "Table 1"
_S51 = "Section 5.1"

_V0 = Reported(0.5, _S51, "≈ 0.5 m/s at the beginning (both shapes)")
_V1 = Reported(5.0, _S51, "≈ 5 m/s on average at the end (both shapes)")


def _table1(initial: tuple, final: tuple) -> dict[str, dict[str, Reported]]:
    """A shape's Table 1 row: (|V|, |E|, |G|) at the start, ((median, sd), ...) at the end."""
    names = ("nodes", "edges", "size")
    return {
        "initial": {**{k: Reported(v, _TABLE1) for k, v in zip(names, initial)}, "velocity": _V0},
        "final": {**{k: Reported(v, _TABLE1, sd=sd) for k, (v, sd) in zip(names, final)},
                  "velocity": _V1},
    }


TABLE1: dict[str, dict[str, dict[str, Reported]]] = {
    "biped": _table1((45, 35, 80), ((88.5, 17.3), (96.5, 26.8), (179.5, 42.2))),
    "worm": _table1((52, 40, 92), ((99.0, 16.6), (115.0, 24.8), (216.0, 39.4))),
}
"""Paper Table 1 (median +/- sd over 10 runs, 3000 generations) and the v_x of section 5.1."""

SIZE_INCREASE = {
    "biped": Reported(1.49, _S51, "149 % median increase in |G|"),
    "worm": Reported(1.35, _S51, "135 % median increase in |G|"),
}
"""Median |G| at the end over |G| at the start, minus 1 (section 5.1)."""

ABLATION = Reported(
    0.001, "Section 5.1.1, Figure 5",
    "topology + weights beat weights only: one-sided Mann-Whitney p < 0.001 for both shapes",
)

RHO_HOMOGENEOUS = {
    "biped": Reported(0.6, "Section 5.2.3, Figure 7", "≈ 0.6: bipeds hover above 60 %"),
    "worm": Reported(0.8, "Section 5.2.3, Figure 7", "≈ 0.8: worms just fall short of 80 %"),
}
"""Median rho at the end of the homogeneous re-optimisation, read off Figure 7."""

RHO_HETEROGENEOUS = Reported(
    None, "Section 5.2.3, Figure 7",
    "partial recovery in \"the more challenging heterogeneous combinations\" (no number)",
)
"""What the paper says of the heterogeneous re-optimisation (its text gives no number)."""

ETA_NEUTRAL = {
    "biped": {"eta_num": Reported(0.60, "Section 5.2.3"), "eta_weight": Reported(0.56,
                                                                               "Section 5.2.3")},
    "worm": {"eta_num": Reported(0.45, "Section 5.2.3"), "eta_weight": Reported(0.38,
                                                                              "Section 5.2.3")},
}
"""Median cut ratios of the homogeneous reassembly (omega 1)."""

ETA_MODULAR = Reported(
    None, "Section 5.2.4, Figure 9",
    "omega 10 stays at eta_num 0.25 to 0.5, higher for omega 1 and 0.1; the three variants "
    "differ significantly",
)

RHO_BY_OMEGA = Reported(
    None, "Section 5.2.4, Figure 8",
    "omega 10 recovers faster and ends higher than omega 1, which ends higher than omega 0.1; "
    "significant at the end except omega 1 vs 10 and omega 1 vs 0.1 for the worm",
)

VELOCITY_BY_OMEGA = Reported(
    None, "Section 5.2.4, Figures 10 and 11",
    "omega 10 slightly slower than omega 1, slower than omega 0.1, not significant; |G| "
    "about the same",
)

DISCOVERY = Reported(
    None, "Section 5.3, Figure 12",
    "b_min 2, b_max 5; the bipeds' most compact module tends to span horizontally, joining "
    "front and rear (less so for worms)",
)

REOPTIMIZATION_GENERATIONS = Reported(510, "Section 5.2.2", "≈ 17 % of the 3000 generations")


def figure3() -> dict:
    """What the paper says of Figure 3's curves: the best's v_x at the start and the end
    (section 5.1) and |G| at the start and the end (Table 1), per shape."""
    return {"velocity_start": _V0.to_dict(), "velocity_end": _V1.to_dict(),
            "size": {shape: {when: rows[when]["size"].to_dict() for when in ("initial", "final")}
                     for shape, rows in TABLE1.items()}}


def everything() -> dict:
    """Every reported number, as JSON-ready data (for report.json)."""
    return {
        "table1": {shape: {when: {k: r.to_dict() for k, r in row.items()}
                           for when, row in rows.items()} for shape, rows in TABLE1.items()},
        "size_increase": {k: r.to_dict() for k, r in SIZE_INCREASE.items()},
        "ablation": ABLATION.to_dict(),
        "rho_homogeneous": {k: r.to_dict() for k, r in RHO_HOMOGENEOUS.items()},
        "rho_heterogeneous": RHO_HETEROGENEOUS.to_dict(),
        "eta_neutral": {shape: {k: r.to_dict() for k, r in row.items()}
                        for shape, row in ETA_NEUTRAL.items()},
        "eta_modular": ETA_MODULAR.to_dict(),
        "rho_by_omega": RHO_BY_OMEGA.to_dict(),
        "velocity_by_omega": VELOCITY_BY_OMEGA.to_dict(),
        "discovery": DISCOVERY.to_dict(),
        "reoptimization_generations": REOPTIMIZATION_GENERATIONS.to_dict(),
    }
