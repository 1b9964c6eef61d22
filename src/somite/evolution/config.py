"""What the graph EA needs: population, selection and variation (operators, omega, partition).

What a *run* needs on top (body, seed, generations, terrains, episodes, checkpoints) is
:class:`somite.experiments.config.RunConfig`.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field, fields

from ..brain.delays import check_delay_per_voxel
from ..errors import bad
from ..limits import MAX_POPULATION, at_most
from ..sim.body import Shape
from ..sim.partition import Partition
from .operators import OperatorConfig

SEEDED_MUTANTS = ("population-1", "population")
_TYPES = {"int": int, "float": (int, float), "str": str, "bool": bool}

OPTION_NAMES = {"partition_spec": "modules"}
"""Fields of :class:`GAConfig` known by another name as options (``--modules``, TOML and
``config.json`` keys, errors): the name users have always written."""


def check_types(cls, values: dict) -> dict:
    """``values`` checked against the scalar field types of dataclass ``cls`` (a one-line
    error naming the field, by its option name), with ints given for float fields made
    floats."""
    types = {f.name: f.type for f in fields(cls)}
    checked = dict(values)
    for name, value in values.items():
        expected = _TYPES.get(types.get(name))
        if expected is None:
            continue  # not a scalar field: a nested configuration checks itself
        if not isinstance(value, expected) or (types[name] != "bool" and isinstance(value, bool)):
            raise bad(OPTION_NAMES.get(name, name), value, f"must be of type {types[name]}")
        if types[name] == "float":
            # Compared before converted: an integer of 400 digits overflows a float.
            if not (-sys.float_info.max <= value <= sys.float_info.max):
                raise bad(name, value, "must be a finite number")
            checked[name] = float(value)
    return checked


@dataclass(frozen=True)
class GAConfig:
    """The paper's EA (Algorithm 1) and the authors' variants of it.

    By default parents are evaluated again every generation, as in the authors' code, which
    produced the paper's figures: with Algorithm 1 as printed (``reevaluate_parents=False``)
    a parent keeps its one lucky evaluation, and robots evolved that way walked less than half as
    fast on unseen terrains (audits/preset-variants.md).

    Attributes
    ----------
    population : int
        n_pop: parents kept, and offspring made, per generation.
    tournament : int
        Tournament size (drawn with replacement).
    reevaluate_parents : bool
        Parents are evaluated again every generation and their fitness replaced (the authors'
        code; the default). False: a parent keeps its one evaluation (Algorithm 1 as printed).
    seeded_mutants : str
        A re-optimisation starts from its genome and ``population-1`` (paper) or
        ``population`` (authors' code) mutants of it.
    partition_spec : str
        The partition the biased operators use when ``operators.omega`` != 1: ``paper``,
        ``worm-halves``, ``biped-legs``, a grid of labels or a partition file (``*.json``);
        the option ``modules`` (:data:`OPTION_NAMES`), read by :meth:`partition`.
    weights_only : bool
        The ablation: weight mutation alone (:meth:`OperatorConfig.weights_only`; the
        probabilities in ``operators`` are ignored).
    operators : OperatorConfig
        Operator probabilities, sigma, omega and node placement.
    delay_per_voxel : float
        Beyond the paper (issue 72): the genomes' length-dependent delays, control steps per
        voxel of an edge's length (:mod:`somite.brain.delays`); 0 (default): one step per edge.
        The first population's genomes carry it, and with them every offspring.
    """

    population: int = 96
    tournament: int = 5
    reevaluate_parents: bool = True
    seeded_mutants: str = "population-1"
    partition_spec: str = "paper"
    weights_only: bool = False
    operators: OperatorConfig = field(default_factory=OperatorConfig)
    delay_per_voxel: float = 0.0

    def __post_init__(self) -> None:
        check_types(GAConfig, {f.name: getattr(self, f.name) for f in fields(self)})
        object.__setattr__(self, "delay_per_voxel",
                           check_delay_per_voxel("delay_per_voxel", self.delay_per_voxel))
        if not isinstance(self.operators, OperatorConfig):
            raise bad("operators", self.operators, "expected an OperatorConfig")
        at_most("population", self.population, MAX_POPULATION)
        for name, low in (("population", 2), ("tournament", 1)):
            if getattr(self, name) < low:
                raise bad(name, getattr(self, name), f"must be at least {low}")
        # Drawn with replacement, so it may exceed the population, but not without bound.
        at_most("tournament", self.tournament, MAX_POPULATION)
        if self.seeded_mutants not in SEEDED_MUTANTS:
            raise bad("seeded_mutants", self.seeded_mutants, f"use one of {SEEDED_MUTANTS}")

    @classmethod
    def option_names(cls) -> set[str]:
        """Every flat option: this class's fields (by :data:`OPTION_NAMES`) and
        :class:`OperatorConfig`'s."""
        own = {OPTION_NAMES.get(f.name, f.name) for f in fields(cls)} - {"operators"}
        return own | {f.name for f in fields(OperatorConfig)}

    @classmethod
    def from_options(cls, options: dict) -> GAConfig:
        """From flat options: this class's fields and :class:`OperatorConfig`'s (``omega``,
        ``p_add_edge``, ...); an unknown key is a one-line error."""
        known = cls.option_names()
        for key, value in options.items():
            if key not in known:
                raise bad(key, value, "unknown option")
        options = check_types(OperatorConfig, options)
        operator_keys = {f.name for f in fields(OperatorConfig)}
        operators = OperatorConfig(**{k: v for k, v in options.items() if k in operator_keys})
        field_of = {option: name for name, option in OPTION_NAMES.items()}
        own = {field_of.get(k, k): v for k, v in options.items() if k not in operator_keys}
        return cls(**own, operators=operators)

    def to_dict(self) -> dict:
        """Flat, by option name: this class's fields and the operators' (the form of TOML and
        config.json)."""
        data = {OPTION_NAMES.get(f.name, f.name): getattr(self, f.name)
                for f in fields(self) if f.name != "operators"}
        if not self.delay_per_voxel:
            # Only when set: every other run keeps the config.json and fingerprint it had.
            del data["delay_per_voxel"]
        return {**data, **self.operators.to_dict()}

    def variation(self) -> OperatorConfig:
        """The operators mutation uses: ``operators``, or weight mutation alone with
        ``weights_only``."""
        return self.operators.weights_only() if self.weights_only else self.operators

    def partition(self, shape: Shape) -> Partition | None:
        """The partition of ``shape`` the biased operators use (None when omega = 1; a
        partition other than the default is checked all the same, not ignored)."""
        if self.operators.omega == 1.0:
            if self.partition_spec != "paper":
                Partition.parse(self.partition_spec, shape)
            return None
        return Partition.parse(self.partition_spec, shape)

    def n_seeded_mutants(self) -> int:
        return self.population - (self.seeded_mutants == "population-1")
