"""Configuration of an evolutionary run, its presets, and loading it from TOML.

Precedence: the preset's values, then the TOML file, then command-line options. Every key of
:class:`EvolutionConfig` can be set in TOML at the top level; unknown keys and wrong types are
one-line errors naming the key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

from ..errors import bad
from ..sim.config import PRESETS as SIM_PRESETS
from ..sim.config import SimConfig
from ..sim.config import preset as sim_preset
from .operators import NODE_PLACEMENTS, OperatorConfig

SEEDED_MUTANTS = ("population-1", "population")
RANDOM_TERRAIN = "hilly-1-10-rnd"
"""The training terrain: a fresh ``hilly-1-10-SEED`` for every evaluation."""


@dataclass(frozen=True)
class EvolutionConfig:
    """Everything that decides an evolutionary run (the paper's values by default).

    ``terrain`` may end in ``-rnd`` (a new random seed in [0, 10000) for every evaluation,
    drawn from the run's generator) or name one fixed terrain. ``modules`` names the partition
    used by the biased operators (``paper``, ``worm-halves``, ``biped-legs`` or a label grid);
    it only matters when ``omega`` != 1. ``start`` names the genome a re-optimisation started
    from (empty for a run from scratch); it then begins with that genome and
    ``seeded_mutants`` mutants of it (``population-1`` in the paper, ``population`` in the
    authors' code, whose first population has one individual more).
    """

    shape: str = "worm"
    sensors: str = "paper"
    preset: str = "paper"
    seed: int = 0
    generations: int = 3000
    population: int = 96
    tournament: int = 5
    terrain: str = RANDOM_TERRAIN
    duration: float = 30.0
    transient: float = 5.0
    reevaluate_parents: bool = False
    omega: float = 1.0
    modules: str = "paper"
    weights_only: bool = False
    p_mutate_edge: float = 0.5
    p_add_edge: float = 0.1
    p_remove_edge: float = 0.1
    p_add_node: float = 0.15
    p_remove_node: float = 0.15
    sigma: float = 0.7
    node_placement: str = "module"
    seeded_mutants: str = "population-1"
    start: str = ""
    checkpoint_every: int = 10

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            expected = {"int": int, "float": (int, float), "str": str, "bool": bool}[f.type]
            if not isinstance(value, expected) or (f.type != "bool" and isinstance(value, bool)):
                raise bad(f.name, value, f"must be of type {f.type}")
            if f.type == "float" and not math.isfinite(value):
                raise bad(f.name, value, "must be a finite number")
        if self.preset not in SIM_PRESETS:
            raise bad("preset", self.preset, f"use one of {list(SIM_PRESETS)}")
        for name, low in (("generations", 0), ("population", 2), ("tournament", 1)):
            if getattr(self, name) < low:
                raise bad(name, getattr(self, name), f"must be at least {low}")
        if self.checkpoint_every < 1:
            raise bad("checkpoint_every", self.checkpoint_every, "must be at least 1")
        if not self.omega > 0:
            raise bad("omega", self.omega, "must be positive")
        if self.seeded_mutants not in SEEDED_MUTANTS:
            raise bad("seeded_mutants", self.seeded_mutants, f"use one of {SEEDED_MUTANTS}")
        if self.node_placement not in NODE_PLACEMENTS:
            raise bad("node_placement", self.node_placement, f"use one of {NODE_PLACEMENTS}")
        self.operators()  # validates the probabilities and sigma
        self.sim()  # validates duration and transient

    def operators(self) -> OperatorConfig:
        """The operator configuration (the fields of the same names); the weights-only
        ablation keeps weight mutation alone."""
        values = {f.name: getattr(self, f.name) for f in fields(OperatorConfig)}
        if self.weights_only:
            values.update(p_mutate_edge=1.0, p_add_edge=0.0, p_remove_edge=0.0, p_add_node=0.0,
                          p_remove_node=0.0)
        return OperatorConfig(**values)

    def n_seeded_mutants(self) -> int:
        return self.population - (self.seeded_mutants == "population-1")

    def sim(self) -> SimConfig:
        return sim_preset(self.preset, duration=float(self.duration),
                          transient=float(self.transient))

    def to_dict(self) -> dict:
        return asdict(self)


EVOLUTION_PRESETS: dict[str, dict] = {
    "paper": {},
    "original-code": {"preset": "original-code", "reevaluate_parents": True,
                      "node_placement": "uniform", "seeded_mutants": "population"},
}
"""The evolutionary half of each preset (decisions.md); ``preset`` also picks the simulator's."""


def _field_types() -> dict[str, str]:
    return {f.name: f.type for f in fields(EvolutionConfig)}


def load_toml(path: str | Path) -> dict:
    """The options of a TOML file, checked for unknown keys (types are checked on build)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise bad("config", str(path), "no such file") from None
    except tomllib.TOMLDecodeError as error:
        raise bad("config", str(path), f"not valid TOML ({error})") from None
    known = _field_types()
    for key in data:
        if key not in known:
            raise bad("config." + key, data[key], "unknown option")
    return data


def resolve(options: dict) -> EvolutionConfig:
    """Build the configuration: preset defaults, then ``options`` (TOML and CLI merged)."""
    name = options.get("preset", "paper")
    if name not in EVOLUTION_PRESETS:
        raise bad("preset", name, f"use one of {list(EVOLUTION_PRESETS)}")
    merged = {**EVOLUTION_PRESETS[name], **options}
    types = _field_types()
    for key, value in merged.items():
        if key not in types:
            raise bad(key, value, "unknown option")
        if types[key] == "float" and isinstance(value, int) and not isinstance(value, bool):
            merged[key] = float(value)
    return replace(EvolutionConfig(), **merged)
