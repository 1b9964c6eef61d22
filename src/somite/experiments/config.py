"""What an evolutionary run needs: its body, seed, length, task and the EA's configuration.

Precedence: the preset's values, then the TOML file, then command-line options. Every key of
:class:`RunConfig`, of :class:`~somite.evolution.config.GAConfig` and of
:class:`~somite.evolution.operators.OperatorConfig` can be set in TOML at the top level (the
form ``config.json`` is written in); unknown keys and wrong types are one-line errors naming
the key.

A :class:`RunConfig` keeps its options as written (its ``config.json``) and parses them once,
when it is built, into :attr:`RunConfig.setup`: the body, the partition, the terrain
distribution, the validation set and the episode settings, which the layers below receive.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

from .._io import read_toml
from ..errors import SomiteError, bad
from ..evolution.config import GAConfig, check_types
from ..limits import MAX_EVALUATIONS, MAX_GENERATIONS, at_most
from ..sim.body import Body
from ..sim.config import PRESETS as SIM_PRESETS
from ..sim.config import SimConfig
from ..sim.config import preset as sim_preset
from ..sim.partition import Partition
from ..tasks.distributions import TerrainDistribution, parse_distribution
from ..tasks.task import Locomotion
from ..tasks.validation import ValidationSet

RANDOM_TERRAIN = "hilly-1-10-rnd"
"""The paper's training terrains: a fresh ``hilly-1-10-SEED`` for every evaluation."""


@dataclass(frozen=True)
class RunSetup:
    """A run's options parsed, once (:attr:`RunConfig.setup`).

    Attributes
    ----------
    body : Body
        From ``shape`` and ``sensors``.
    partition : Partition or None
        The partition the biased operators use (``modules``; None when omega is 1).
    terrains : TerrainDistribution
        The training distribution (``terrain``).
    validation : ValidationSet
        The validation terrains the log's ``validation_velocity`` is measured on.
    sim : SimConfig
        The episode settings (``preset``, ``duration``, ``transient``).
    """

    body: Body
    partition: Partition | None
    terrains: TerrainDistribution
    validation: ValidationSet
    sim: SimConfig


@dataclass(frozen=True)
class RunConfig:
    """Everything that decides an evolutionary run (the paper's values by default).

    Attributes
    ----------
    shape, sensors : str
        The body (``Body.build(shape, sensors)``).
    preset : str
        Simulator preset (``paper`` or ``original-code``).
    seed : int
        Seeds the one ``SeedSequence`` both of the EA's generators are spawned from.
    generations : int
        Generations after the initial population (the log has ``generations + 1`` rows).
    terrain : str
        The training distribution (:mod:`somite.tasks.distributions`).
    duration, transient : float
        Episode length and start of the measured interval [s].
    evaluations : int
        Terrains per evaluation, fitness their mean v_x (1: the paper).
    validate_every : int
        Every this many generations (and at the last one) the current best is run on the
        fixed validation terrains, its mean v_x logged as ``validation_velocity``; 0: never.
    start : str
        The genome a re-optimisation started from (empty for a run from scratch).
    checkpoint_every : int
        Generations between checkpoints (one is also written at generation 0 and at the end).
    ga : GAConfig
        The EA's own configuration.
    """

    shape: str = "worm"
    sensors: str = "paper"
    preset: str = "paper"
    seed: int = 0
    generations: int = 3000
    terrain: str = RANDOM_TERRAIN
    duration: float = 30.0
    transient: float = 5.0
    evaluations: int = 1
    validate_every: int = 50
    start: str = ""
    checkpoint_every: int = 10
    ga: GAConfig = field(default_factory=GAConfig)

    def __post_init__(self) -> None:
        check_types(RunConfig, {f.name: getattr(self, f.name) for f in fields(self)})
        if self.preset not in SIM_PRESETS:
            raise bad("preset", self.preset, f"use one of {list(SIM_PRESETS)}")
        for name, low in (("generations", 0), ("evaluations", 1), ("validate_every", 0),
                          ("checkpoint_every", 1)):
            if getattr(self, name) < low:
                raise bad(name, getattr(self, name), f"must be at least {low}")
        if not 0 <= self.seed < 2**32:
            raise bad("seed", self.seed, "must be in [0, 2**32)")
        at_most("generations", self.generations, MAX_GENERATIONS)
        at_most("evaluations", self.evaluations, MAX_EVALUATIONS)
        terrains = parse_distribution(self.terrain)
        body = Body.build(self.shape, self.sensors)  # shape and sensors, before any run starts
        try:  # and the partition omega uses, for that shape
            partition = self.ga.partition(body.shape)
        except SomiteError as error:
            raise bad("modules", self.ga.partition_spec, str(error).split(": ", 1)[-1]) from None
        sim = sim_preset(self.preset, duration=float(self.duration),
                         transient=float(self.transient))
        # Not a field: config.json, equality and the fingerprint are the options as written.
        object.__setattr__(self, "_setup", RunSetup(body, partition, terrains, ValidationSet(),
                                                    sim))
        self.task()  # refuses a validation terrain as the training terrain

    @property
    def setup(self) -> RunSetup:
        """The options parsed (when this configuration was built)."""
        return self._setup

    def body(self) -> Body:
        return self._setup.body

    def task(self, body: Body | None = None, backend: str = "cpu") -> Locomotion:
        """The task this run evolves on; with ``body``, genomes of another body are refused.
        ``backend`` (``cpu``, ``cuda``) is where its episodes run, not part of the run. Every
        task of a run shares its :attr:`setup` (its validation terrains are built once)."""
        setup = self._setup
        return Locomotion(setup.terrains, evaluations=self.evaluations, sim=setup.sim,
                          validation=setup.validation, body=body, backend=backend)

    def validation_due(self, generation: int) -> bool:
        """Whether ``generation``'s best gets a validation velocity in the log."""
        if self.validate_every == 0:
            return False
        return generation % self.validate_every == 0 or generation == self.generations

    def to_dict(self) -> dict:
        """Flat, as in TOML and ``config.json``."""
        data = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "ga"}
        return {**data, **self.ga.to_dict()}


RUN_PRESETS: dict[str, dict] = {
    "paper": {},
    "original-code": {"preset": "original-code", "reevaluate_parents": True,
                      "node_placement": "uniform", "seeded_mutants": "population"},
}
"""The run half of each preset (docs/decisions.md, "Presets"), plain data; ``preset`` also
picks the simulator's half (:data:`somite.sim.config.PRESETS`)."""


def option_names() -> set[str]:
    """Every key a TOML file or ``config.json`` may hold."""
    return {f.name for f in fields(RunConfig)} - {"ga"} | GAConfig.option_names()


def load_toml(path: str | Path) -> dict:
    """The options of a TOML file, checked for unknown keys (types are checked on build)."""
    data = read_toml(path, "config")
    known = option_names()
    for key in data:
        if key not in known:
            raise bad("config." + key, data[key], "unknown option")
    if "start" in data:
        # Recorded by a re-optimisation in its config.json, never read as an instruction:
        # a run given it would claim a start it never had.
        raise bad("config.start", data["start"], "a run's start genome is not an option: "
                  "re-optimise it with `somite reoptimize GENOME`")
    return data


def resolve(options: dict) -> RunConfig:
    """Build the configuration: preset defaults, then ``options`` (TOML and CLI merged, flat)."""
    name = options.get("preset", "paper")
    if not isinstance(name, str) or name not in RUN_PRESETS:
        raise bad("preset", name, f"use one of {list(RUN_PRESETS)}")
    merged = {**RUN_PRESETS[name], **options}
    known = option_names()
    for key, value in merged.items():
        if key not in known:
            raise bad(key, value, "unknown option")
    own = {f.name for f in fields(RunConfig)} - {"ga"}
    run = check_types(RunConfig, {k: v for k, v in merged.items() if k in own})
    ga = GAConfig.from_options({k: v for k, v in merged.items() if k not in own})
    return RunConfig(**run, ga=ga)
