"""An evolved genome's controller as a policy: observations in, actions out, from Python.

The compiled episode runs a graph controller inside its loop: after the physics of
[k - 1, k] / 60 s it reads the sensors and computes actuation k, in force over [k, k + 1] / 60 s;
actuation 0 is 0 (docs/architecture.md, "Step 0"). The policy's answer to an episode's first
observation is that 0, and the environments do not put a first action in force anyway.
:class:`GenomePolicy` runs the same compiled :func:`~somite.brain.kernels.graph_step` on the
observations an environment returns (the readings after each step), so fed back as actions its
output is the actuation the compiled loop puts in force, bit for bit: the robot moves as
``somite simulate`` moves it (tested in tests/test_gym.py).

The policy keeps state per environment (the nodes' values of the last step: one step of delay
per edge), so it has to know when an environment starts a new episode: ``first`` says which
observations are an episode's first (``info["step"] == 0`` in :mod:`somite.envs`).
"""

from __future__ import annotations

import numpy as np

from ..brain.compile import compile_genome
from ..brain.controllers import GraphArrays
from ..brain.genome import Genome
from ..brain.kernels import graph_of, graph_step
from ..errors import bad
from ..sim.config import preset as sim_preset


class GenomePolicy:
    """``genome``'s controller as a policy for ``n_envs`` environments at once.

    ``policy(obs, first)``: ``obs`` (R,) or (n_envs, R) the readings after a control step,
    ``first`` a bool (or one per environment) saying which are an episode's first observation
    (after a reset); returns the actions (V,) or (n_envs, V) in [-1, 1] for the next step.
    ``hidden_activation`` is the preset's (``tanh`` for ``paper``, ``sigmoid`` for
    ``original-code``).
    """

    def __init__(self, genome: Genome, n_envs: int = 1, hidden_activation: str = "tanh"):
        if not isinstance(genome, Genome):
            raise bad("genome", type(genome).__name__, "expected a somite Genome")
        if hidden_activation not in ("tanh", "sigmoid"):
            raise bad("hidden_activation", hidden_activation, "use 'tanh' or 'sigmoid'")
        if isinstance(n_envs, bool) or not isinstance(n_envs, int) or n_envs < 1:
            raise bad("n_envs", n_envs, "must be a positive integer")
        self.genome = genome
        self.graph: GraphArrays = compile_genome(genome)
        self.n_envs = n_envs
        self.n_readings = genome.body.n_readings
        self.n_voxels = genome.body.shape.n_voxels
        self._sigmoid = hidden_activation == "sigmoid"
        self._kernel_graph = graph_of(self.graph)
        n = max(1, self.graph.n_nodes)
        # Two buffers a row that take turns, as in the compiled loop: a step reads what the one
        # before wrote.
        self._h = np.zeros((n_envs, 2, n))
        self._k = np.zeros(n_envs, dtype=np.int64)
        self._actuation = np.zeros((n_envs, self.n_voxels))

    def __call__(self, obs, first) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        single = obs.ndim == 1
        rows = obs[None] if single else obs
        if rows.shape != (self.n_envs, self.n_readings):
            expected = (self.n_readings,) if self.n_envs == 1 else (self.n_envs, self.n_readings)
            raise bad("obs", f"shape {obs.shape}", f"must have shape {expected}")
        starts = np.asarray(first, dtype=bool)
        if starts.shape not in ((), (self.n_envs,)):
            raise bad("first", f"shape {starts.shape}", f"one bool, or one per env ({self.n_envs})")
        starts = np.broadcast_to(starts, (self.n_envs,))
        graph = self._kernel_graph
        for e in range(self.n_envs):
            if starts[e]:
                # A new episode: the actuation over its step 1 is 0, the nodes start at 0.
                self._h[e] = 0.0
                self._actuation[e] = 0.0
                self._k[e] = 0
            else:
                self._k[e] += 1
                k = self._k[e]
                old, new = (self._h[e, 0], self._h[e, 1]) if k % 2 == 1 else (self._h[e, 1],
                                                                             self._h[e, 0])
                graph_step(graph, old, new, np.ascontiguousarray(rows[e]), self._actuation[e],
                           self._sigmoid)
        actions = self._actuation.copy()
        return actions[0] if single else actions


def policy(genome: Genome, n_envs: int = 1, preset: str = "paper") -> GenomePolicy:
    """``genome``'s controller as a :class:`GenomePolicy` for ``n_envs`` environments of
    preset ``preset`` (which decides the hidden neurons' activation)."""
    return GenomePolicy(genome, n_envs, sim_preset(preset).hidden_activation)


__all__ = ["GenomePolicy", "policy"]
