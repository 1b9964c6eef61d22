"""The locomotion task as an object: training terrains, episode settings and validation.

A :class:`Locomotion` owns everything that decides how fast a genome is: the distribution of
training terrains, the :class:`~somite.sim.config.SimConfig` of an episode, how many terrains
one evaluation averages, and the fixed validation terrains. It draws its randomness only from
the generator it is given, so the same generator state gives the same velocities, and an EA
can hand it a generator of its own that variation never touches.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from .. import checks
from ..brain.compile import compile_genome
from ..brain.genome import Genome
from ..errors import bad
from ..limits import MAX_BATCH, MAX_DURATION, MAX_EVALUATIONS, MAX_VALIDATION
from ..sim.body import Body
from ..sim.config import CONTROL_HZ, SimConfig
from ..sim.config import PRESETS as SIM_PRESETS
from ..sim.config import preset as sim_preset
from ..sim.terrain import Terrain
from . import arguments
from .distributions import TerrainDistribution, parse_distribution
from .locomotion import Controller, Outcome, simulate_batch
from .validation import VALIDATION_COUNT, ValidationSet, is_fresh_terrain
from .validation import evaluate as evaluate_on
from .velocity import mean_velocity


class Episodes(NamedTuple):
    """Episodes to run: robot i is (bodies[i], terrains[i], controllers[i]) with noise seed
    seeds[i]."""

    bodies: list[Body]
    terrains: list[Terrain]
    controllers: list[Controller]
    seeds: np.ndarray


class Locomotion:
    """Move right as fast as possible: fitness v_x [m/s], the centre of mass's mean x-velocity
    over [transient, duration] (paper eq. 2).

    Parameters
    ----------
    terrain : str or TerrainDistribution
        A training distribution: ``hilly-H-W-rnd`` (default ``hilly-1-10-rnd``, the paper's),
        ``steppy-H-W-rnd``, ``uphill-rnd``, ``downhill-rnd``, or a fixed terrain such as
        ``flat`` (see :mod:`somite.tasks.distributions`), or one already parsed.
    duration : float
        Episode length [s] (30 in the paper).
    evaluations : int
        Terrains drawn per evaluation; a genome's fitness is the mean v_x over them, NaN if
        any is NaN (1 is the paper).
    preset : str
        Simulator preset, ``paper`` or ``original-code``.
    transient : float
        Start of the measured interval [s] (5 in the paper).
    validation : int or ValidationSet
        How many fixed validation terrains :meth:`validate` uses (``hilly-1-10-10000``, ...;
        never training terrains), or the set itself (its terrains, once built, are shared).
    body : Body, optional
        When given, every genome evaluated must drive this body (a one-line error otherwise).
    sim : SimConfig, optional
        The full episode settings; replaces ``duration``, ``preset`` and ``transient``.
    backend : str
        Where episodes run: ``cpu`` (default) or ``cuda`` (an NVIDIA GPU, with
        ``pip install somite[cuda]``). Both run the same code; velocities agree to ~1e-9.
    """

    def __init__(
        self,
        terrain: str | TerrainDistribution = "hilly-1-10-rnd",
        duration: float = 30.0,
        *,
        evaluations: int = 1,
        preset: str = "paper",
        transient: float = 5.0,
        validation: int | ValidationSet = VALIDATION_COUNT,
        body: Body | None = None,
        sim: SimConfig | None = None,
        backend: str = "cpu",
    ) -> None:
        self.backend = arguments.backend("backend", backend)
        self.terrains = (terrain if isinstance(terrain, TerrainDistribution)
                         else parse_distribution(checks.text("terrain", terrain)))
        # Checked even when ``sim`` replaces them: a bad value is never passed over in silence.
        duration = checks.real("duration", duration, 1 / CONTROL_HZ, MAX_DURATION)
        transient = checks.real("transient", transient, 0.0, MAX_DURATION)
        checks.text("preset", preset, list(SIM_PRESETS))
        self.sim = (arguments.sim_config("sim", sim) if sim is not None
                    else sim_preset(preset, duration=duration, transient=transient))
        self.evaluations = checks.integer("evaluations", evaluations, 1, MAX_EVALUATIONS)
        if not isinstance(validation, ValidationSet):
            checks.integer("validation", validation, 1, MAX_VALIDATION)
        self.validation = ValidationSet.of(validation)
        if not self.terrains.is_random and self.terrains.name in self.validation.names:
            raise bad("terrain", terrain if isinstance(terrain, str) else self.terrains.name,
                      "a validation terrain cannot be a training terrain")
        if not self.terrains.is_random and is_fresh_terrain(self.terrains.name):
            raise bad("terrain", terrain if isinstance(terrain, str) else self.terrains.name,
                      "a fresh terrain (hilly-1-10-20000 to -20999, where somite report and "
                      "evaluate --fresh measure robots nothing chose) cannot be a training "
                      "terrain")
        self.body = None if body is None else arguments.body("body", body)

    @property
    def validation_terrains(self) -> list[Terrain]:
        """The fixed validation terrains :meth:`validate` runs on (built at the first use)."""
        return self.validation.terrains

    def __repr__(self) -> str:
        return (f"Locomotion(terrain={self.terrains.name!r}, duration={self.sim.duration}, "
                f"evaluations={self.evaluations})")

    def _check(self, genomes: Sequence[Genome]) -> list[Genome]:
        genomes = arguments.genomes("genomes", genomes, MAX_BATCH)
        for genome in genomes:
            if self.body is not None and genome.body != self.body:
                raise bad("shape", genome.body.shape.grid_string(),
                          f"the task's body is {self.body.shape.grid_string()}")
        return genomes

    def evaluate(self, genomes: Sequence[Genome], rng: np.random.Generator) -> np.ndarray:
        """Fitness of each genome, shape (G,), v_x in m/s (NaN: the episode went non-finite).

        Each genome meets ``evaluations`` terrains drawn from the training distribution, with
        its own sensor-noise seed per episode, all from ``rng``: first the G*K terrains
        (genome by genome), then the G*K noise seeds. One batch for all of them.
        """
        return self.evaluate_counted(genomes, rng)[0]

    def evaluate_counted(self, genomes: Sequence[Genome],
                         rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`evaluate`'s fitness (the same draws), and for each genome how many of its
        episodes had a non-finite step (:attr:`~somite.tasks.locomotion.Outcome.non_finite`)."""
        episodes = self.episodes(genomes, rng)
        if not episodes.seeds.size:
            return np.zeros(0), np.zeros(0, dtype=np.int64)
        outcomes, _ = simulate_batch(episodes.bodies, episodes.terrains, episodes.controllers,
                                     self.sim, episodes.seeds, backend=self.backend)
        return self.fitness([o.velocity for o in outcomes]), self.non_finite(outcomes)

    def episodes(self, genomes: Sequence[Genome], rng: np.random.Generator) -> Episodes:
        """The episodes :meth:`evaluate` runs for ``genomes``, drawn from ``rng`` as it draws
        them; several tasks' episodes of the same ``sim`` can run in one batch."""
        genomes = self._check(genomes)
        checks.instance("rng", rng, np.random.Generator, "a numpy Generator "
                        "(ea.rng_evaluation, numpy.random.default_rng(seed))")
        n = len(genomes) * self.evaluations
        if n == 0:
            return Episodes([], [], [], np.zeros(0, dtype=np.int64))
        terrains = self.terrains.sample(rng, n)
        noise_seeds = rng.integers(0, 2**32, n)
        arrays = [compile_genome(g) for g in genomes]
        repeat = self.evaluations
        return Episodes([g.body for g in genomes for _ in range(repeat)], terrains,
                        [a for a in arrays for _ in range(repeat)], noise_seeds)

    def fitness(self, velocities: Sequence[float]) -> np.ndarray:
        """Fitness (G,) from the v_x of :meth:`episodes`' episodes, in their order."""
        return mean_velocity(np.asarray(velocities, dtype=np.float64).reshape(
            -1, self.evaluations), axis=1)

    def non_finite(self, outcomes: Sequence[Outcome]) -> np.ndarray:
        """For each genome (G,), how many of :meth:`episodes`' episodes, given in their order,
        had a non-finite step."""
        flagged = np.array([o.non_finite > 0 for o in outcomes], dtype=np.int64)
        return flagged.reshape(-1, self.evaluations).sum(axis=1)

    def validate(self, genomes: Genome | Sequence[Genome]) -> np.ndarray:
        """v_x [m/s] on each fixed validation terrain: shape (T,) for one genome, (G, T) for a
        list. No randomness: noise seed 0, so the same genome always gets the same numbers."""
        single = isinstance(genomes, Genome)
        checked = self._check([genomes] if single else genomes)
        velocities = evaluate_on(checked, self.validation_terrains, self.sim,
                                 backend=self.backend)
        return velocities[0] if single else velocities

    def validation_velocity(self, genome: Genome) -> float:
        """Mean v_x [m/s] of ``genome`` over the validation terrains (NaN if any is NaN)."""
        return float(mean_velocity(self.validate(genome)))


def simulate(
    robot: Genome | Controller,
    terrain: str | Terrain = "flat",
    *,
    body: Body | None = None,
    duration: float = 30.0,
    preset: str = "paper",
    seed: int = 0,
    sim: SimConfig | None = None,
    backend: str = "cpu",
) -> Outcome:
    """One robot, one episode: its :class:`~somite.tasks.locomotion.Outcome` (v_x in m/s over
    [5 s, duration], distance in m, final centre of mass in m, ...).

    ``robot`` is a :class:`~somite.brain.genome.Genome` (which carries its body) or a
    controller (``Zero()``, ``Sine(...)``, ...) with ``body``. ``terrain`` is a name
    (``flat``, ``hilly-1-10-3``, ...) or a :class:`~somite.sim.terrain.Terrain`; ``seed`` seeds
    the sensor noise; ``backend`` is ``cpu`` or ``cuda``. For batches, see
    :func:`somite.tasks.locomotion.simulate_batch`.

    Actuation i is in force over [i, i + 1] / 60 s; actuation 0 is 0 whatever the controller
    (docs/architecture.md, "Step 0"), as in :class:`somite.Episode` and ``somite/Locomotion-v0``,
    so ``Table(actions)`` replays an environment's actions bit for bit.
    """
    arguments.robot("robot", robot)
    if body is not None:
        arguments.body("body", body)
    if isinstance(robot, Genome):
        if body is not None and body != robot.body:
            raise bad("body", body.shape.grid_string(), "differs from the genome's own body")
        body, controller = robot.body, compile_genome(robot)
    elif body is None:
        raise bad("body", None, "a controller needs body=; a Genome carries its own")
    else:
        controller = robot
    world = arguments.terrain("terrain", terrain)
    # Checked even when ``sim`` replaces them: a bad value is never passed over in silence.
    duration = checks.real("duration", duration, 1 / CONTROL_HZ, MAX_DURATION)
    checks.text("preset", preset, list(SIM_PRESETS))
    config = (arguments.sim_config("sim", sim) if sim is not None
              else sim_preset(preset, duration=duration))
    seed = checks.integer("seed", seed, 0, checks.SEED_END - 1)
    [outcome], _ = simulate_batch([body], [world], [controller], config, seeds=seed,
                                  backend=arguments.backend("backend", backend))
    return outcome


__all__ = ["Locomotion", "simulate"]
