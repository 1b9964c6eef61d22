"""somite: embodied, self-organizing, modular neural controllers for 2-D voxel-based soft robots.

An implementation of Pigozzi & Medvet, "Evolving Modularity in Soft Robots through an Embodied
and Self-Organizing Neural Controller" (Artificial Life, 2022).

The public API (docs/guide.md, "Python API"; docs/api.rst)::

    import somite
    body = somite.Body.build("worm")
    task = somite.Locomotion(terrain="hilly-1-10-rnd", duration=30.0)
    ea = somite.GraphEA(body, population=96, seed=0)
    for _ in range(100):
        genomes = ea.ask()
        ea.tell(genomes, task.evaluate(genomes, rng=ea.rng_evaluation))
    task.validate(ea.best)                  # v_x [m/s] on each validation terrain
    somite.simulate(ea.best, terrain="flat")  # an Outcome

Names are loaded on first use, so ``import somite`` (and the command line) stays quick.
With Gymnasium installed (``pip install somite[gym]``), ``gymnasium.make("somite/Locomotion-v0")``
works after ``import somite`` (see :mod:`somite.envs`).
"""

from __future__ import annotations

import sys
from importlib import import_module
from importlib.util import find_spec

__version__ = "0.1.0"

_EXPORTS = {
    "Body": "somite.sim.body",
    "Shape": "somite.sim.body",
    "SimConfig": "somite.sim.config",
    "Terrain": "somite.sim.terrain",
    "parse_terrain": "somite.sim.terrain",
    "Genome": "somite.brain.genome",
    "Sine": "somite.brain.controllers",
    "Zero": "somite.brain.controllers",
    "Table": "somite.brain.controllers",
    "GAConfig": "somite.evolution.config",
    "OperatorConfig": "somite.evolution.operators",
    "GraphEA": "somite.evolution.ea",
    "Locomotion": "somite.tasks.task",
    "simulate": "somite.tasks.task",
    "Outcome": "somite.tasks.locomotion",
    "simulate_batch": "somite.tasks.locomotion",
    "Episode": "somite.tasks.stepper",
    "evaluate_genomes": "somite.tasks.validation:evaluate",
    "validation_terrains": "somite.tasks.validation",
    "fresh_terrains": "somite.tasks.validation",
    "fresh_noise": "somite.tasks.validation",
    "preset": "somite.sim.config",
    "record_episode": "somite.viz.video",
    "render_episode": "somite.viz.video",
    "analyse_gait": "somite.analysis.gait",
    "ReplayRun": "somite.viz.replay",
    "write_replay": "somite.viz.replay",
    "TerrainDistribution": "somite.tasks.distributions",
    "mean_velocity": "somite.tasks.velocity",
    "rho": "somite.tasks.velocity",
    "RunConfig": "somite.experiments.config",
    "resolve": "somite.experiments.config",
    "evolve": "somite.experiments.runner",
    "evolve_lockstep": "somite.experiments.lockstep",
    "SomiteError": "somite.errors",
    "policy": "somite.envs.policy",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'somite' has no attribute {name!r}")
    # "module:attribute" exports a name under another one.
    module, _, attribute = _EXPORTS[name].partition(":")
    value = getattr(import_module(module), attribute or name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])


class _RegisterWithGymnasium:
    """An import hook that registers ``somite/Locomotion-v0`` as soon as Gymnasium is imported.

    Registering imports Gymnasium (0.2-0.5 s), which ``import somite``, and so every command,
    should not pay when no one uses it. The hook looks at nothing but the name of each module
    imported until Gymnasium's, registers once Gymnasium's has run, and removes itself. When
    Gymnasium was imported before somite, somite registers at once (below).
    """

    def find_spec(self, name, path=None, target=None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        exec_module = spec.loader.exec_module

        def exec_then_register(module):
            exec_module(module)
            try:
                import_module("somite.envs").register()
            except Exception as error:  # a Gymnasium somite cannot use must still import
                import warnings

                warnings.warn(f"somite/Locomotion-v0 is not registered: {error}", stacklevel=2)

        spec.loader.exec_module = exec_then_register
        return spec


if "gymnasium" in sys.modules:
    import_module("somite.envs").register()
elif not any(isinstance(hook, _RegisterWithGymnasium) for hook in sys.meta_path):
    sys.meta_path.insert(0, _RegisterWithGymnasium())
