"""Any value of any type given to any argument of the public API (issue 46): either a result,
or a SomiteError (a ValueError; a TypeError too for a wrong type) whose one-line message
starts with the argument's name. Never another exception, a crash or a hang.

Each call replaces one argument of a valid call by a drawn value; episodes are one or a few
control steps, so that a value that is accepted costs little to run."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import somite
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.sim.config import BOUNDS, CHOICES, SimConfig

TINY = SimConfig(duration=1 / 60, transient=0.0)
SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture,
                                           HealthCheck.too_slow])

ANY = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(-2, 70),
    st.floats(allow_nan=True, allow_infinity=True), st.floats(0, 2),
    st.complex_numbers(max_magnitude=10), st.text(max_size=6), st.binary(max_size=4),
    st.lists(st.integers(-3, 3), max_size=3), st.lists(st.text(max_size=3), max_size=2),
    st.tuples(st.integers(0, 3), st.integers(0, 3)), st.dictionaries(st.text(max_size=3),
                                                                      st.integers(), max_size=2),
    st.sampled_from(["flat", "worm", "biped", "paper", "cpu", "hilly-1-10-3", "2x2", "tanh",
                     "hilly-1-10-rnd", "1e400", "nan", "-1"]),
    st.builds(object), st.just(np.float64(np.nan)), st.just(np.int64(3)),
    st.just(np.array([1.0, 2.0])), st.just(np.zeros((2, 2))), st.just(math.inf),
    st.just(10**400),
)
"""Values of every kind: what a careless or hostile caller might pass."""


@pytest.fixture(scope="module")
def genome(worm):
    return initial_genome(worm, np.random.default_rng(46))


def answered(field: str, call) -> None:
    """``call()`` returns, or raises a one-line SomiteError naming ``field`` first."""
    try:
        call()
    except SomiteError as error:
        message = str(error)
        assert message.startswith(field), (field, message)
        assert "\n" not in message, message


@SETTINGS
@given(name=st.sampled_from(sorted([*BOUNDS, *CHOICES, "lidar_angles"])), value=ANY)
def test_simconfig(name, value):
    answered(name, lambda: SimConfig(**{name: value}))


@SETTINGS
@given(argument=st.sampled_from(["shape", "sensors"]), value=ANY)
def test_body_build(argument, value):
    arguments = {"shape": "worm", "sensors": "paper", argument: value}
    answered(argument, lambda: somite.Body.build(**arguments))


@SETTINGS
@given(argument=st.sampled_from(["robot", "terrain", "body", "duration", "preset", "seed",
                                 "sim", "backend"]), value=ANY)
def test_simulate(genome, argument, value):
    arguments = {"robot": genome, "terrain": "flat", "duration": 1 / 60, "sim": TINY,
                 argument: value}
    if argument == "duration":
        arguments["sim"] = None
    answered(argument, lambda: somite.simulate(**arguments))


@SETTINGS
@given(argument=st.sampled_from(["robots", "terrains", "config", "seeds", "record", "bodies"]),
       value=ANY)
def test_episode(genome, argument, value):
    arguments = {"robots": [genome], "terrains": "flat", "config": TINY, argument: value}
    answered(argument, lambda: somite.Episode(**arguments))


@SETTINGS
@given(value=ANY)
def test_episode_step(genome, value):
    episode = somite.Episode([genome], "flat", SimConfig(duration=2 / 60))
    answered("actuation", lambda: episode.step(value))


@SETTINGS
@given(argument=st.sampled_from(["genomes", "terrains", "config", "seed", "backend"]),
       value=ANY)
def test_evaluate_genomes(genome, argument, value):
    arguments = {"genomes": [genome], "terrains": ["flat"], "config": TINY, argument: value}
    answered(argument, lambda: somite.evaluate_genomes(**arguments))


@SETTINGS
@given(argument=st.sampled_from(["terrain", "duration", "evaluations", "preset", "transient",
                                 "validation", "body", "sim", "backend"]), value=ANY)
def test_locomotion(argument, value):
    arguments = {"terrain": "flat", "sim": TINY, argument: value}
    if argument in ("duration", "transient", "preset"):
        arguments["sim"] = None
    answered(argument, lambda: somite.Locomotion(**arguments))


@SETTINGS
@given(argument=st.sampled_from(["population", "seed", "start", "omega", "tournament"]),
       value=ANY)
def test_graph_ea(worm, argument, value):
    answered(argument, lambda: somite.GraphEA(worm, **{"population": 4, argument: value}))


@SETTINGS
@given(fitness=st.lists(ANY, min_size=4, max_size=4) | ANY, non_finite=ANY | st.none())
def test_tell(worm, fitness, non_finite):
    ea = somite.GraphEA(worm, population=4, seed=0)
    genomes = ea.ask()
    try:
        ea.tell(genomes, fitness, non_finite=non_finite)
    except SomiteError as error:
        # The fitness is checked first, then the count.
        assert str(error).startswith(("fitness", "non_finite")), str(error)
        assert "\n" not in str(error)
        return
    # What was told is plain JSON in the EA's state.
    json.dumps(ea.state(), allow_nan=False)
