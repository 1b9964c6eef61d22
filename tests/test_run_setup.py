"""A run's configuration is parsed once (RunConfig.setup): one ``somite evolve`` parses each of
its strings once and builds the validation terrains at most once, and the layers below get the
parsed objects."""

from __future__ import annotations

import sys
from collections import Counter

import numpy as np
import pytest

import somite.sim.config
import somite.sim.terrain
import somite.tasks.distributions
import somite.tasks.validation
from somite.cli import main
from somite.errors import SomiteError
from somite.experiments.config import resolve
from somite.sim.body import Body, Shape


def count_calls(monkeypatch, function) -> Counter:
    """Count the calls of ``function`` by first argument, under whatever name somite's
    modules imported it."""
    calls: Counter = Counter()

    def counting(*args, **kwargs):
        calls[args[0] if args else None] += 1
        return function(*args, **kwargs)

    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("somite"):
            continue
        for name, value in list(vars(module).items()):
            if value is function:
                monkeypatch.setattr(module, name, counting)
    return calls


def count_method(monkeypatch, cls, name: str) -> Counter:
    """Count the calls of the classmethod ``cls.name`` by first argument."""
    calls: Counter = Counter()
    original = getattr(cls, name).__func__

    def counting(klass, *args, **kwargs):
        calls[args[0] if args else None] += 1
        return original(klass, *args, **kwargs)

    monkeypatch.setattr(cls, name, classmethod(counting))
    return calls


def test_one_evolve_parses_each_string_once(tmp_path, monkeypatch, capsys):
    distributions = count_calls(monkeypatch, somite.tasks.distributions.parse_distribution)
    names = count_calls(monkeypatch, somite.sim.terrain.parse_name)
    validations = count_calls(monkeypatch, somite.tasks.validation.validation_terrains)
    presets = count_calls(monkeypatch, somite.sim.config.preset)
    shapes = count_method(monkeypatch, Shape, "parse")
    bodies = count_method(monkeypatch, Body, "build")
    assert main(["evolve", "--shape", "biped", "--population", "4", "--generations", "2",
                 "--duration", "1", "--quiet", "--out", str(tmp_path / "run")]) == 0
    capsys.readouterr()
    assert distributions == {"hilly-1-10-rnd": 1}
    assert names == {"hilly-1-10-rnd": 1}
    assert shapes == {"biped": 1} and bodies == {"biped": 1}
    assert presets == {"paper": 1}
    assert validations == {10: 1}  # the last generation's best is validated, once


def test_the_setup_is_what_the_layers_receive():
    config = resolve({"shape": "worm", "terrain": "flat", "duration": 2.0, "omega": 2.0})
    setup = config.setup
    assert setup.body is config.body() and setup.body.shape == Shape.parse("worm")
    assert setup.terrains.name == "flat" and not setup.terrains.is_random
    assert setup.partition is not None and setup.partition.shape == setup.body.shape
    assert setup.sim.duration == 2.0 and setup.sim.transient == 5.0
    assert setup.validation.count == 10
    first, second = config.task(), config.task(setup.body, "cpu")
    assert first.terrains is second.terrains is setup.terrains
    assert first.sim is setup.sim and first.validation is setup.validation
    assert first.validation_terrains is second.validation_terrains  # built once
    # The setup is no part of the configuration: equal options, equal configurations.
    assert config == resolve(config.to_dict()) and "setup" not in config.to_dict()


@pytest.mark.parametrize("options, field", [
    ({"terrain": "hilly-1-10-10004"}, "terrain"),
    ({"terrain": "hilly-1-10"}, "terrain"),
    ({"shape": "12x1x"}, "shape"),
    ({"duration": -1.0}, "duration"),
])
def test_a_bad_string_is_refused_when_the_configuration_is_built(options, field):
    with pytest.raises(SomiteError, match=f"^{field}="):
        resolve(options)


def test_a_reoptimisation_builds_its_validation_terrains_once(tmp_path, monkeypatch):
    from somite.evolution.operators import initial_genome
    from somite.experiments.reoptimize import reoptimize

    start = initial_genome(Body.build("biped"), np.random.default_rng(0))
    config = resolve({"shape": "biped", "population": 4, "generations": 1, "duration": 1.0})
    validations = count_calls(monkeypatch, somite.tasks.validation.validation_terrains)
    _, rows, donors = reoptimize(config, tmp_path / "run", start, donors=[start], n_terrains=10)
    assert validations == {10: 1}  # the log's, the donors' and the transfer curve's, shared
    assert len(rows) == 2 and len(donors) == 1


def test_a_biased_run_parses_its_partition_once(tmp_path, monkeypatch, capsys):
    from somite.sim.partition import Partition

    partitions = count_method(monkeypatch, Partition, "parse")
    out = tmp_path / "run"
    common = ["--population", "4", "--duration", "1", "--quiet", "--out", str(out)]
    assert main(["evolve", "--shape", "worm", "--omega", "10", "--modules", "worm-halves",
                 "--generations", "1", *common]) == 0
    capsys.readouterr()
    assert partitions == {"worm-halves": 1}


def test_a_resumed_run_parses_its_partition_once(tmp_path, monkeypatch, capsys):
    from somite.sim.partition import Partition

    out = tmp_path / "run"
    common = ["--population", "4", "--duration", "1", "--quiet", "--out", str(out),
              "--checkpoint-every", "1"]
    assert main(["evolve", "--shape", "worm", "--omega", "10", "--modules", "worm-halves",
                 "--generations", "1", *common]) == 0
    config = (out / "config.json").read_bytes()
    partitions = count_method(monkeypatch, Partition, "parse")
    assert main(["evolve", "--resume", "--generations", "2", *common]) == 0
    assert partitions == {"worm-halves": 2}  # the saved configuration, then with 2 generations
    assert b'"generations": 2' in (out / "config.json").read_bytes() != config
    partitions.clear()
    assert main(["evolve", "--resume", *common]) == 0  # nothing left to do, nothing changed
    capsys.readouterr()
    assert partitions == {"worm-halves": 1}
