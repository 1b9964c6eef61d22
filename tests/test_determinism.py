"""Same inputs and seed, same numbers; a robot's outcome does not depend on its batch."""

from __future__ import annotations

import numpy as np

from somite.bench import random_graph
from somite.brain.controllers import Sine, Zero
from somite.sim.config import SimConfig
from somite.sim.terrain import hilly, parse_terrain
from somite.tasks.locomotion import simulate_batch


def test_same_inputs_same_numbers(worm):
    g = random_graph(worm, 200, np.random.default_rng(0))
    config = SimConfig(duration=3.0)
    runs = [simulate_batch([worm], [hilly(1.0, 10.0, 4)], [g], config, seeds=11, record=True)[1]
            for _ in range(2)]
    for field in ("com", "pos", "readings", "actuation", "contact"):
        np.testing.assert_array_equal(getattr(runs[0], field), getattr(runs[1], field))


def test_outcome_independent_of_batch(worm, biped):
    g = random_graph(worm, 200, np.random.default_rng(1))
    terrain = hilly(1.0, 10.0, 9)
    config = SimConfig(duration=3.0)
    alone, trace_alone = simulate_batch([worm], [terrain], [g], config, seeds=5)
    others = [biped, worm, biped]
    batch, trace_batch = simulate_batch(
        others + [worm],
        [parse_terrain("flat"), hilly(1.0, 10.0, 2), parse_terrain("uphill-10"), terrain],
        [Sine(), random_graph(worm, 300, np.random.default_rng(2)), Zero(), g],
        config,
        seeds=[1, 2, 3, 5],
    )
    assert batch[-1] == alone[0]
    np.testing.assert_array_equal(trace_batch.com[-1], trace_alone.com[0])
