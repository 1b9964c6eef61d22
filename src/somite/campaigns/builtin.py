"""The built-in campaigns: the paper's experiments at three budgets, one structure.

``paper`` is the paper's budget (sections 5.1-5.3); ``quick`` the same structure at about
1/60 of its evaluations per run, a few hours on 2 cores (``somite campaign list`` gives its
robot-control-steps and a time estimate); ``smoke`` every stage at a budget of seconds, for
tests and for trying the machinery out. Only the numbers in :data:`BUDGETS` differ.
"""

from __future__ import annotations

from ..errors import bad
from .spec import Campaign, parse

BUDGETS: dict[str, dict] = {
    "paper": {"seeds": 10, "defaults": {"generations": 3000, "population": 96},
              "reoptimize": 510, "validation": 10},
    # 3 seeds (the fewest for which run i + run i+1 pairs differ from run i+1 + run i), a third
    # of the population, 1/20 of the generations; re-optimisation keeps the paper's 17% ratio.
    # 5.3e8 robot-control-steps: about 3.5 h at the 2-core figure of BENCHMARKS.md (~40k/s).
    "quick": {"seeds": 3, "defaults": {"generations": 150, "population": 32,
                                       "validate_every": 25},
              "reoptimize": 25, "validation": 10},
    "smoke": {"seeds": 2, "defaults": {"generations": 2, "population": 4, "duration": 1.0,
                                       "validate_every": 2},
              "reoptimize": 1, "validation": 2},
}

SHAPES = ["biped", "worm"]


def structure(budget: dict) -> dict:
    """The campaign of the paper's experiments at ``budget`` (a :data:`BUDGETS` entry)."""
    grid = {"kind": "evolve", "shapes": SHAPES, "seeds": budget["seeds"]}
    reoptimize = {"generations": budget["reoptimize"]}
    return {
        "title": "Pigozzi & Medvet (2022): RQ1-RQ3",
        "validation": budget["validation"],
        "defaults": dict(budget["defaults"]),
        "experiments": {
            "rq1": {**grid, "title": "Effectiveness of the graph controller",
                    "paper": "Section 5.1: Table 1, Figures 3, 4, 5"},
            "ablation": {**grid, "options": {"weights_only": True},
                         "title": "Ablation: weights-only mutation",
                         "paper": "Section 5.1: Figures 3, 5 (weights only)"},
            "omega-10": {**grid, "options": {"omega": 10.0},
                         "title": "Modularity fostered (omega 10)",
                         "paper": "Section 5.2.4: Figures 8, 9, 10, 11"},
            "omega-0.1": {**grid, "options": {"omega": 0.1},
                          "title": "Modularity discouraged (omega 0.1)",
                          "paper": "Section 5.2.4: Figures 8, 9, 10, 11"},
            "rq2-homo": {"kind": "reassemble", "donors": "rq1", "pairing": "next",
                         "reoptimize": reoptimize,
                         "title": "Homogeneous reassembly (back of run i + front of run i+1)",
                         "paper": "Section 5.2: Figure 7, eta"},
            "rq2-hetero": {"kind": "reassemble", "donors": "rq1", "pairing": "cross",
                           "reoptimize": reoptimize,
                           "title": "Heterogeneous reassembly (biped <-> worm)",
                           "paper": "Section 5.2: Figure 7"},
            "omega-reassembly": {"kind": "reassemble", "donors": ["omega-10", "omega-0.1"],
                                 "pairing": "next", "reoptimize": reoptimize,
                                 "title": "Reassembly of the omega runs",
                                 "paper": "Section 5.2.4: Figures 8, 9"},
            "rq3-discovery": {"kind": "discover", "genomes": "rq1", "b_min": 2, "b_max": 5,
                              "title": "Automatic module discovery",
                              "paper": "Section 5.3: Figures 12, 13"},
            "rq3-reassembly": {"kind": "reassemble", "donors": "rq1", "pairing": "next",
                               "modules_from": "rq3-discovery", "reoptimize": reoptimize,
                               "title": "Reassembly along the discovered modules",
                               "paper": "beyond the paper"},
        },
    }


def builtin(name: str) -> Campaign:
    """The built-in campaign ``name``."""
    if name not in BUDGETS:
        raise bad("campaign", name, f"no such built-in campaign; use one of {list(BUDGETS)} "
                  "or a .toml file")
    return parse(structure(BUDGETS[name]), name=name, source=f"builtin:{name}")
