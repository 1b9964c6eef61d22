"""Every registered terrain kind (somite.sim.terrain.TERRAIN_KINDS), checked the same way: its
names read back as themselves, build a walled profile, have one spelling, refuse bad numbers in
one line naming the number, and its distribution draws reproducibly from the generator it is
given."""

from __future__ import annotations

import numpy as np
import pytest

from somite.errors import SomiteError
from somite.sim.terrain import (
    DISTRIBUTION_HELP,
    LENGTH,
    MAX_NUMBER_CHARS,
    RANDOM,
    TERRAIN_HELP,
    TERRAIN_KINDS,
    WALL_HEIGHT,
    _fmt,
    parse_name,
    parse_terrain,
)
from somite.tasks.distributions import parse_distribution
from somite.tasks.validation import VALIDATION_COUNT, ValidationSet

DRAWN = [kind for kind, entry in TERRAIN_KINDS.items() if entry.sample is not None]
FIELDS = [(kind, field) for kind, entry in TERRAIN_KINDS.items() for field in entry.grammar]


def spelled(field, value) -> str:
    return str(int(value)) if field.whole else _fmt(value)


def misspelled(field) -> str:
    """The example of ``field`` spelled another way: a leading zero, or a trailing one."""
    text = spelled(field, field.example)
    if field.whole:
        return "0" + text
    return text + ("0" if "." in text else ".0")


def name_of(kind: str, **given: str) -> str:
    """``kind``'s name from its fields' examples, with the numbers ``given`` by letter."""
    grammar = TERRAIN_KINDS[kind].grammar
    return "-".join([kind, *(given.get(f.letter, spelled(f, f.example)) for f in grammar)])


def refused(text: str, parse=parse_terrain) -> str:
    with pytest.raises(SomiteError) as info:
        parse(text)
    message = str(info.value)
    assert message.startswith(f"terrain={text!r}: ") and "\n" not in message
    return message


@pytest.mark.parametrize("kind", TERRAIN_KINDS)
def test_a_name_reads_back_as_itself(kind):
    name = name_of(kind)
    assert parse_terrain(name).name == name
    assert parse_name(name) == (kind, tuple(f.example for f in TERRAIN_KINDS[kind].grammar))
    assert name.split("-")[0] == kind and "-".join(
        [kind, *(f.letter for f in TERRAIN_KINDS[kind].grammar)]) in TERRAIN_HELP


@pytest.mark.parametrize("kind", TERRAIN_KINDS)
def test_a_kind_builds_a_walled_profile(kind):
    terrain = parse_terrain(name_of(kind))
    assert np.all(np.isfinite(terrain.xs)) and np.all(np.isfinite(terrain.ys))
    assert np.all(np.diff(terrain.xs) > 0)
    assert terrain.xs[0] == 0 and terrain.xs[-1] >= LENGTH - 1e-9
    assert terrain.ys[0] >= terrain.ys[1] + WALL_HEIGHT - 1e-9  # the left wall
    assert terrain.start_x == terrain.xs[1]
    assert parse_terrain(name_of(kind)).ys.tolist() == terrain.ys.tolist()  # no randomness


@pytest.mark.parametrize("kind, field", FIELDS)
def test_a_number_has_one_spelling(kind, field):
    message = refused(name_of(kind, **{field.letter: misspelled(field)}))
    assert message.endswith(f": write it {name_of(kind)}")


@pytest.mark.parametrize("kind, field", FIELDS)
def test_a_bad_number_is_one_line_naming_it(kind, field):
    long = refused(name_of(kind, **{field.letter: "1" * (MAX_NUMBER_CHARS + 1)}))
    assert long.endswith(f"{field.letter} has more than {MAX_NUMBER_CHARS} characters")
    reasons = set()
    for value in ("0", "9" * (MAX_NUMBER_CHARS - 1)):
        text = name_of(kind, **{field.letter: value})
        try:
            parse_terrain(text)
        except SomiteError:
            reasons.add(refused(text).split(": ", 1)[1])
    assert reasons == {why for _, why in field.checks}
    assert all(field.letter in why for why in reasons)
    refused(name_of(kind, **{field.letter: "x"}))  # not a number: an unknown terrain


@pytest.mark.parametrize("kind", DRAWN)
def test_a_distribution_draws_reproducibly_from_its_generator(kind):
    grammar = TERRAIN_KINDS[kind].grammar
    name = "-".join([kind, *(spelled(f, f.example) for f in grammar[:-1]), RANDOM])
    assert "-".join([kind, *(f.letter for f in grammar[:-1]), RANDOM]) in DISTRIBUTION_HELP
    distribution = parse_distribution(name)
    assert distribution.is_random and distribution.name == name
    draws = []
    for _ in range(2):
        rng = np.random.default_rng(3)
        draws.append([t.name for t in distribution.sample(rng, 40)] + [rng.random()])
    assert draws[0] == draws[1]
    other = [t.name for t in distribution.sample(np.random.default_rng(4), 40)]
    assert other != draws[0][:-1]
    for terrain_name in draws[0][:-1]:  # each draw is a terrain of the kind, of those numbers
        kind_read, values = parse_name(terrain_name)
        assert kind_read == kind
        assert values[:-1] == tuple(f.example for f in grammar[:-1])
    if len(grammar) > 1:  # its fixed numbers have one spelling too
        other = "-".join([kind, misspelled(grammar[0]),
                          *(spelled(f, f.example) for f in grammar[1:-1]), RANDOM])
        assert refused(other, parse_distribution).endswith(f": write it {name}")


@pytest.mark.parametrize("kind", TERRAIN_KINDS)
def test_a_fixed_terrain_is_a_distribution_that_draws_nothing(kind):
    distribution = parse_distribution(f" {name_of(kind)} ")
    assert not distribution.is_random and distribution.name == name_of(kind)
    rng = np.random.default_rng(0)
    drawn = distribution.sample(rng, 3)
    assert [t.name for t in drawn] == [name_of(kind)] * 3
    assert rng.random() == np.random.default_rng(0).random()


@pytest.mark.parametrize("kind", [k for k in TERRAIN_KINDS if k not in DRAWN])
def test_a_kind_without_a_draw_has_no_distribution(kind):
    message = refused(f"{kind}-{RANDOM}", parse_distribution)
    assert "unknown terrain distribution" in message


def test_an_unknown_kind_names_every_kind():
    message = refused("bumpy-1")
    assert message.endswith(f"unknown terrain; use {TERRAIN_HELP}")
    assert all(kind in TERRAIN_HELP for kind in TERRAIN_KINDS)


def test_the_validation_set_is_one_constant_and_never_a_training_draw():
    validation = ValidationSet()
    assert validation.count == VALIDATION_COUNT == 10
    assert validation.names == [f"hilly-1-10-{10000 + i}" for i in range(10)]
    assert [t.name for t in validation.terrains] == validation.names
    assert validation.terrains is validation.terrains  # built once
    training = {t.name for t in parse_distribution("hilly-1-10-rnd").sample(
        np.random.default_rng(0), 2000)}
    assert not training & set(validation.names)
    with pytest.raises(SomiteError, match="^validation=0: "):
        ValidationSet(0)
