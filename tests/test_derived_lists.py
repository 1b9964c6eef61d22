"""Lists derived from their tables (issue 69): the task kinds from their modules, the
controller union, its command-line text and parser from ``CONTROLLER_TYPES``, observation names'
sensor components from ``SENSORS``. A toy added to each table reaches the derived list."""

from __future__ import annotations

import dataclasses
import types

import pytest

from somite.brain import control
from somite.brain.control import (
    CONTROLLER_HELP,
    CONTROLLER_TYPES,
    WRITTEN,
    Controller,
    ControllerType,
    parse_controller,
)
from somite.brain.controllers import Sine, Zero
from somite.campaigns import kinds
from somite.campaigns.kinds import EXPERIMENT_KINDS, MODULES, TASK_KINDS, TaskKind
from somite.cli import main
from somite.envs.settings import settings
from somite.sim import sensor_kinds
from somite.sim.body import Body
from somite.sim.sensor_kinds import SENSORS, SensorKind, component_name

from .conftest import expect_error


def test_task_kinds_are_their_modules_read_by_name():
    assert list(TASK_KINDS) == [m.__name__.rpartition(".")[2] for m in MODULES]
    for module, kind in zip(MODULES, TASK_KINDS.values()):
        assert kind == TaskKind.of(module)
        assert kind.run is module.run and kind.outputs is module.OUTPUTS
    assert EXPERIMENT_KINDS == tuple(n for n, k in TASK_KINDS.items() if k.expand is not None)
    assert TASK_KINDS["reoptimize"].expand is None and TASK_KINDS["reoptimize"].fields == set()


def test_a_toy_kind_module_is_a_kind():
    toy = types.ModuleType("somite.campaigns.kinds.toy")
    for name in ("run", "check", "read", "progress", "estimate", "expand", "parse"):
        setattr(toy, name, lambda *args, name=name: name)
    toy.OUTPUTS, toy.FIELDS = frozenset({"toy.json"}), frozenset({"size"})
    kind = TaskKind.of(toy)
    assert kind.expand() == "expand" and kind.parse() == "parse" and kind.run() == "run"
    assert kind.outputs == {"toy.json"} and kind.fields == {"size"}
    del toy.expand, toy.parse, toy.FIELDS  # made by another kind's experiment
    assert TaskKind.of(toy).expand is None and TaskKind.of(toy).fields == frozenset()
    assert kinds.kind("evolve", "kind") is TASK_KINDS["evolve"]


def test_the_controller_union_and_its_text_follow_the_table():
    assert Controller.__args__ == tuple(entry.spec for entry in CONTROLLER_TYPES)
    assert CONTROLLER_HELP == "zero, or sine:freq=F,amp=A,phase=P (1, 1, -1)"
    for name in WRITTEN:
        assert name in CONTROLLER_HELP
        assert parse_controller(name) == CONTROLLER_TYPES[control.TYPE_CODE[name]].spec()
    assert parse_controller("sine:amp=0.5") == Sine(amp=0.5) and parse_controller("zero") == Zero()
    message = expect_error("controller", lambda: parse_controller("table"))
    assert message.endswith("use zero or sine:freq=F,amp=A,phase=P")


def test_a_toy_controller_with_number_fields_is_written_and_parsed(monkeypatch):
    @dataclasses.dataclass(frozen=True)
    class Toy:
        gain: float = 2.0
        period: int = 3

    fields = control._text_fields(Toy)
    assert [f.name for f in fields] == ["gain", "period"]
    assert control._written("toy", fields, True) == "toy:gain=G,period=P (2, 3)"
    toy = ControllerType("toy", Toy, "Toy(...)", lambda specs, n_voxels: {})
    monkeypatch.setattr(control, "CONTROLLER_TYPES", (*CONTROLLER_TYPES, toy))
    monkeypatch.setattr(control, "TYPE_CODE", {**control.TYPE_CODE, "toy": len(CONTROLLER_TYPES)})
    monkeypatch.setitem(control.WRITTEN, "toy", fields)
    assert parse_controller("toy:gain=0.5") == Toy(gain=0.5)
    expect_error("controller", lambda: parse_controller("toy:phase=1"))


def test_simulate_s_help_is_the_tables(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    assert " ".join(CONTROLLER_HELP.split()) in " ".join(capsys.readouterr().out.split())


def test_observation_names_end_with_the_table_s_component_names(monkeypatch):
    assert [component_name("velocity", c) for c in (0, 1)] == ["velocity.x", "velocity.y"]
    assert [component_name("lidar", c) for c in range(5)] == [f"lidar.{c}" for c in range(5)]
    assert component_name("touch", 0) == "touch"
    names = settings(shape="biped", sensors="all").observation_names
    assert len(set(names)) == len(names) == Body.build("biped", "all").n_readings
    assert "v0(0,0).velocity.x" in names and "v0(0,0).lidar.4" in names
    # A wider toy kind, appended to the table, gets numbered names of its own.
    toy = SensorKind("toy", 3, (1, 2, 3), 3, ())
    monkeypatch.setattr(sensor_kinds, "SENSORS", (*SENSORS, toy))
    monkeypatch.setitem(sensor_kinds.SENSOR_CODE, "toy", len(SENSORS))
    assert [component_name("toy", c) for c in range(3)] == ["toy.0", "toy.1", "toy.2"]
