"""The built-in campaigns: the paper's experiments at three budgets, one structure, and its
RQ1 alone at the paper's budget.

``paper`` is the paper's budget (sections 5.1-5.3); ``quick`` the same structure at about
1/60 of its evaluations per run, a few hours on 2 cores (``somite campaign list`` gives its
robot-control-steps and a time estimate); ``smoke`` every stage at a budget of seconds, for
tests and for trying the machinery out. Only the numbers in :data:`BUDGETS` differ.
``paper-rq1`` is RQ1 and the weights-only ablation (section 5.1) at the paper's settings,
:data:`RQ1_SEEDS` seeds per shape and variant; ``paper-rq1:N`` and ``paper:N`` the same with N
seeds (seeds 0..N-1: the runs of fewer seeds are among them, unchanged). ``paper``'s RQ1 and
ablation runs are ``paper-rq1``'s, so a ``paper-rq1`` folder grows into ``paper:N``
(:data:`GROWS_FROM`). ``paper``'s experiments are ordered so that its partial results mean
something early: the stages on RQ1's runs (re-optimised reassembly, homogeneous then
heterogeneous; module discovery) come before the omega runs, which a campaign starts seed by
seed. ``lengths`` is beyond the paper (issue 72): the neutral EA beside the distance-biased edge
addition and the length-dependent delays, ``lengths-smoke`` the same at the smoke budget;
``lengths:N`` with N seeds (a campaign of its own: its reassemblies pair run i with run i + 1 of
N, so a folder of fewer seeds does not grow into it). Every experiment declares the figures it
feeds (:data:`DECLARED_FIGURES`, :mod:`.figures`). :data:`BUILTINS` lists them all.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from ..errors import bad
from ..tasks.validation import VALIDATION_COUNT
from .spec import Campaign, parse

BUDGETS: dict[str, dict] = {
    "paper": {"seeds": 10, "defaults": {"generations": 3000, "population": 96},
              "reoptimize": 510, "validation": VALIDATION_COUNT},
    # 3 seeds (the fewest for which run i + run i+1 pairs differ from run i+1 + run i), a third
    # of the population, 1/20 of the generations; re-optimisation keeps the paper's 17% ratio.
    # 5.3e8 robot-control-steps: about 1.5 h at the 2-core figure of BENCHMARKS.md (100k/s).
    "quick": {"seeds": 3, "defaults": {"generations": 150, "population": 32,
                                       "validate_every": 25},
              "reoptimize": 25, "validation": VALIDATION_COUNT},
    "smoke": {"seeds": 2, "defaults": {"generations": 2, "population": 4, "duration": 1.0,
                                       "validate_every": 2},
              "reoptimize": 1, "validation": 2},
}

SHAPES = ["biped", "worm"]
RQ1_SEEDS = 3
"""Seeds per shape and variant of ``paper-rq1`` (issue 26: at least 3; the paper ran 10)."""
DECLARED_FIGURES: dict[str, dict[str, str]] = {
    "rq1": {"table1": "", "figure3": "omega 1", "figure5": "topology + weights",
            "figure10": "omega 1 (neutral)"},
    "ablation": {"figure5": "weights only"},
    "omega-10": {"figure10": "omega 10 (more modular)"},
    "omega-0.1": {"figure10": "omega 0.1 (less modular)"},
    "rq2-homo": {"figure7": "homogeneous", "figure8": ""},
    "rq2-hetero": {"figure7": "heterogeneous"},
    "omega-reassembly": {"figure8": ""},
    "rq3-reassembly": {"discovered": "discovered modules"},
}
"""The figures each experiment of the built-ins feeds, and its label there. The report also
reads this for a campaign directory written before experiments declared their figures."""


def structure(budget: dict) -> dict:
    """The campaign of the paper's experiments at ``budget`` (a :data:`BUDGETS` entry)."""
    grid = {"kind": "evolve", "shapes": SHAPES, "seeds": budget["seeds"]}
    reoptimize = {"generations": budget["reoptimize"]}
    out = {
        "title": "Pigozzi & Medvet (2022): RQ1-RQ3",
        "validation": budget["validation"],
        "defaults": dict(budget["defaults"]),
        "experiments": {
            **_rq1(grid),
            "rq2-homo": {"kind": "reassemble", "donors": "rq1", "pairing": "next",
                         "reoptimize": reoptimize,
                         "title": "Homogeneous reassembly (back of run i + front of run i+1)",
                         "paper": "Section 5.2: Figure 7, eta"},
            "rq2-hetero": {"kind": "reassemble", "donors": "rq1", "pairing": "cross",
                           "reoptimize": reoptimize,
                           "title": "Heterogeneous reassembly (biped <-> worm)",
                           "paper": "Section 5.2: Figure 7"},
            "rq3-discovery": {"kind": "discover", "genomes": "rq1", "b_min": 2, "b_max": 5,
                              "title": "Automatic module discovery",
                              "paper": "Section 5.3: Figures 12, 13"},
            "omega-10": {**grid, "options": {"omega": 10.0},
                         "title": "Modularity fostered (omega 10)",
                         "paper": "Section 5.2.4: Figures 8, 9, 10, 11"},
            "omega-0.1": {**grid, "options": {"omega": 0.1},
                          "title": "Modularity discouraged (omega 0.1)",
                          "paper": "Section 5.2.4: Figures 8, 9, 10, 11"},
            "omega-reassembly": {"kind": "reassemble", "donors": ["omega-10", "omega-0.1"],
                                 "pairing": "next", "reoptimize": reoptimize,
                                 "title": "Reassembly of the omega runs",
                                 "paper": "Section 5.2.4: Figures 8, 9"},
            "rq3-reassembly": {"kind": "reassemble", "donors": "rq1", "pairing": "next",
                               "modules_from": "rq3-discovery", "reoptimize": reoptimize,
                               "title": "Reassembly along the discovered modules",
                               "paper": "beyond the paper"},
        },
    }
    return _declared(out)


def _declared(campaign: dict) -> dict:
    """``campaign`` with each experiment's figures (:data:`DECLARED_FIGURES`) declared."""
    for name, table in campaign["experiments"].items():
        table["figures"] = DECLARED_FIGURES.get(name, {})
    return campaign


def _rq1(grid: dict) -> dict:
    """The experiments of RQ1: the graph controller, and its weights-only ablation."""
    return {
        "rq1": {**grid, "title": "Effectiveness of the graph controller",
                "paper": "Section 5.1: Table 1, Figures 3, 4, 5"},
        "ablation": {**grid, "options": {"weights_only": True},
                     "title": "Ablation: weights-only mutation",
                     "paper": "Section 5.1.1: Figure 5 (weights only)"},
    }


def paper_rq1(seeds: int = RQ1_SEEDS) -> dict:
    """RQ1 and the ablation at the paper's settings (its ``paper`` budget: 3000 generations
    of 96, parents re-evaluated, 30 s episodes on a fresh hilly-1-10 terrain each, the
    defaults of a run), ``seeds`` runs per shape and variant."""
    budget = BUDGETS["paper"]
    grid = {"kind": "evolve", "shapes": SHAPES, "seeds": seeds}
    return _declared({"title": "Pigozzi & Medvet (2022): RQ1 and the weights-only ablation",
                      "validation": budget["validation"], "defaults": dict(budget["defaults"]),
                      "experiments": _rq1(grid)})


# -- beyond the paper (issue 72): edges that cost their length -----------------------------------

EDGE_LENGTH_BUDGETS: dict[str, dict] = {
    # quick's population and validation; 200 generations, re-optimisation at quick's 17%:
    # 5.0e8 robot-control-steps, ~84 min by `somite campaign list`'s rate; paper-rq1 ran 2.5
    # times its estimate, so some 3.5 h on 2 free cores.
    "lengths": {"seeds": 3, "defaults": {"generations": 200, "population": 32,
                                         "validate_every": 25},
                "reoptimize": 34, "validation": VALIDATION_COUNT},
    "lengths-smoke": {**BUDGETS["smoke"], "seeds": 3},
}
EDGE_LENGTH_VARIANTS: dict[str, tuple[dict, str]] = {
    "neutral": ({}, "The paper's EA (omega 1): every edge one step, any pair as likely"),
    "distance-bias": ({"distance_bias": 1.0},
                      "Edge addition biased against long edges: a pair d voxels apart weighs "
                      "exp(-d)"),
    "length-delay": ({"delay_per_voxel": 1.0},
                     "Delays that grow with length: max(1, ceil(d)) steps for an edge of d "
                     "voxels"),
}
"""The three EAs the edge-length comparison runs: options, title."""


def edge_length(budget: dict) -> dict:
    """The comparison of issue 72 at ``budget``: the neutral EA, the distance-biased edge
    addition and the length-dependent delays, both shapes, and each one's homogeneous
    reassembly (run i's back or legs with run i+1's front or torso), re-optimised; Figure 3
    (v_x and |G|), the final bests' edge lengths and Figure 7 (rho) put the three side by
    side."""
    grid = {"kind": "evolve", "shapes": SHAPES, "seeds": budget["seeds"]}
    runs, reassemblies = {}, {}
    for name, (options, title) in EDGE_LENGTH_VARIANTS.items():
        runs[name] = {**grid, **({"options": dict(options)} if options else {}),
                      "title": title, "paper": "Section 4 (limitations): beyond the paper",
                      "figures": {"figure3": name, "edge-lengths": name}}
        reassemblies[f"{name}-homo"] = {
            "kind": "reassemble", "donors": name, "pairing": "next",
            "reoptimize": {"generations": budget["reoptimize"]},
            "title": f"Homogeneous reassembly of the {name} runs",
            "paper": "Section 5.2: Figure 7, beyond the paper", "figures": {"figure7": name}}
    return {"title": "Edges that cost their length, delays that grow with it (issue 72)",
            "validation": budget["validation"], "defaults": dict(budget["defaults"]),
            "experiments": {**runs, **reassemblies}}


BUILTINS: dict[str, Callable[[], dict]] = {
    **{name: partial(structure, budget) for name, budget in BUDGETS.items()},
    "paper-rq1": paper_rq1,
    **{name: partial(edge_length, budget) for name, budget in EDGE_LENGTH_BUDGETS.items()},
}
"""Every built-in campaign: name -> its campaign file's content."""

SEEDED: dict[str, Callable[[int], dict]] = {
    "paper": lambda seeds: structure({**BUDGETS["paper"], "seeds": seeds}),
    "paper-rq1": paper_rq1,
    **{name: (lambda seeds, budget=budget: edge_length({**budget, "seeds": seeds}))
       for name, budget in EDGE_LENGTH_BUDGETS.items()},
}
"""The built-ins that take a count of seeds (``NAME:N``): name -> its content at N seeds."""

GROWS_FROM: dict[str, tuple[str, ...]] = {"paper": ("paper-rq1",)}
"""Campaign name -> the built-ins whose tasks it holds unchanged (same settings and seeds,
so the same numbers): a folder of one of these grows into it with ``--resume``, its finished
runs kept (``paper:3`` over ``paper-rq1``'s folder adds the omega runs and the reassemblies
beside the 12 runs of RQ1)."""


def builtin(name: str) -> Campaign:
    """The built-in campaign ``name`` (``paper:N``, ``paper-rq1:N``, ``lengths:N``: with N
    seeds)."""
    base, _, seeds = name.partition(":")
    if base not in BUILTINS or (seeds and base not in SEEDED):
        raise bad("campaign", name, f"no such built-in campaign; use one of {list(BUILTINS)} "
                  f"({', '.join(n + ':N' for n in SEEDED)} for N seeds) or a .toml file")
    if not seeds:
        return parse(BUILTINS[name](), name=name, source=f"builtin:{name}")
    if not seeds.isdigit() or not 1 <= int(seeds) <= 10_000:
        raise bad("campaign", name, f"{base}:N takes a count of seeds N from 1 to 10000")
    return parse(SEEDED[base](int(seeds)), name=base, source=f"builtin:{name}")


def is_builtin(name: str) -> bool:
    """Whether ``name`` names a built-in campaign (rather than a file)."""
    return name.partition(":")[0] in BUILTINS
