"""The version of somite's physics: the one name for "what a simulation step computes".

A run's numbers depend on its options and on the simulator that steps its robots. The options
are in its ``config.json``; the simulator is named here. Whoever changes what a step computes
(``physics.py``, ``joint_lanes.py``, ``tasks/lanes.py``, the episode's order of passes, a
preset's constants: anything after which a seeded run's rows differ) bumps :data:`PHYSICS`
in the same commit, so that a run started under the old physics is not resumed under the new
one without the user saying so (:mod:`somite.experiments.physics`; docs/decisions.md,
"Physics versions"). A change that keeps every number bit for bit (a faster loop, another
thread count) leaves it as it is.
"""

PHYSICS = "somite-physics-1"
"""Version 1: the sequential-impulse solver with the block rotations of ``sim.trig.sincos``
(commit 1898296, kernel round 2), the first physics a run records. Runs of earlier commits
(libm's cosines, the last digits differ) record none."""

__all__ = ["PHYSICS"]
