"""Hostile input (issue 23): one spelling per terrain name, numbers too long to read, strict
JSON, and a standard output that is closed, full or a closed pipe."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from somite.cli import main
from somite.commands.common import print_json
from somite.errors import SomiteError
from somite.sim.body import Shape
from somite.sim.terrain import TERRAIN_HELP, hilly, parse_terrain
from somite.tasks.distributions import parse_distribution

SOMITE = str(Path(sys.executable).with_name("somite"))
LONG = "1" * 5000
"""An integer over Python's int-string limit (4300 digits)."""


def one_line_error(capsys, code, expected: int = 2) -> str:
    """The one stderr line of a command that failed with ``expected``, without traceback."""
    assert code == expected
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def run_main(capsys, *args, expected: int = 2) -> str:
    try:
        code = main(list(args))
    except SystemExit as stop:  # argparse's errors
        code = stop.code
    return one_line_error(capsys, code, expected)


# -- terrain names: one spelling each ------------------------------------------------------------


@pytest.mark.parametrize("name, spelled", [
    ("hilly-1-10-010000", "hilly-1-10-10000"),
    ("hilly-1.0-10-10005", "hilly-1-10-10005"),
    ("hilly-1-10.0-10009", "hilly-1-10-10009"),
    ("hilly-01-10-3", "hilly-1-10-3"),
    ("hilly-0.50-10-3", "hilly-0.5-10-3"),
    ("steppy-1-10.00-3", "steppy-1-10-3"),
    ("hilly-1.10000000000000000001-10-3", "hilly-1.1-10-3"),
    ("uphill-05", "uphill-5"),
    ("downhill-2.50", "downhill-2.5"),
])
def test_another_spelling_is_refused_naming_the_one(name, spelled):
    with pytest.raises(SomiteError) as info:
        parse_terrain(name)
    assert str(info.value) == f"terrain={name!r}: write it {spelled}"
    assert parse_terrain(spelled).name == spelled


@pytest.mark.parametrize("name, spelled", [
    ("hilly-1.0-10-rnd", "hilly-1-10-rnd"),
    ("steppy-1-010-rnd", "steppy-1-10-rnd"),
    ("hilly-1-10-010000", "hilly-1-10-10000"),
])
def test_distributions_have_one_spelling_too(name, spelled):
    with pytest.raises(SomiteError, match=f"write it {spelled}$"):
        parse_distribution(name)
    assert parse_distribution(spelled).name == spelled


@pytest.mark.parametrize("name", ["hilly-1-10-10000", "hilly-1-10-010000", "hilly-1.0-10-10005",
                                  "hilly-1-10.0-10009", " hilly-1-10-10003 "])
def test_validation_terrains_cannot_be_trained_on_under_any_spelling(name):
    from somite.tasks.task import Locomotion

    with pytest.raises(SomiteError, match="^terrain="):
        Locomotion(terrain=name)


@pytest.mark.parametrize("name", ["hilly-1-10-20000", "hilly-1-10-20019", "hilly-1-10-20999"])
def test_fresh_terrains_cannot_be_trained_on(name):
    """The report measures every final best on them: a run trained there would be measured on
    its own training terrain."""
    from somite.tasks.task import Locomotion

    with pytest.raises(SomiteError, match=f"^terrain='{name}': a fresh terrain"):
        Locomotion(terrain=name)
    for beside in ("hilly-1-10-19999", "hilly-1-10-21000", "hilly-2-10-20000"):
        assert Locomotion(terrain=beside).terrains.name == beside


def test_the_names_somite_writes_read_back_as_themselves():
    for terrain in (hilly(1.0, 10.0, 42), hilly(2.5, 4.0, 0), hilly(0.00001, 10.0, 1),
                    hilly(1000.0, 0.1, 2**63 - 1)):
        assert parse_terrain(terrain.name).name == terrain.name
    assert hilly(0.00001, 10.0, 1).name == "hilly-0.00001-10-1"  # no exponent
    assert parse_terrain("uphill-59.5").name == "uphill-59.5"
    assert "1 not 1.0" in TERRAIN_HELP


@pytest.mark.parametrize("name, why", [
    ("hilly-" + "1" * 400 + "-10-3", "H has more than 30 characters"),
    ("hilly-1-" + "1" * 400 + "-3", "W has more than 30 characters"),
    (f"hilly-1-10-{LONG}", "SEED has more than 30 characters"),
    (f"uphill-{LONG}", "DEG has more than 30 characters"),
    ("hilly-1001-10-3", "the height H must be at most 1000 m"),
    ("steppy-1-1000.5-3", "the step width W must be at most 1000 m"),
    ("hilly-1-0-3", "the step width W must be positive"),
    ("hilly-1-10-9223372036854775808", "SEED must be below 2**63 (a Java long)"),
    ("uphill-60", "slopes must be under 60 degrees"),
    ("hilly-\u0661-10-3", "unknown terrain"),  # an Arabic-Indic digit one
])
def test_numbers_out_of_bounds_are_refused(name, why):
    with pytest.raises(SomiteError) as info:
        parse_terrain(name)
    assert why in str(info.value) and "\n" not in str(info.value)


def test_sizes_of_distributions_are_bounded():
    for name in ("hilly-" + "1" * 400 + "-10-rnd", "hilly-2000-10-rnd", "steppy-1-0-rnd"):
        with pytest.raises(SomiteError, match="^terrain="):
            parse_distribution(name)


# -- numbers too long to read ---------------------------------------------------------------------


@pytest.mark.parametrize("args, field", [
    (["simulate", "--terrain", f"hilly-1-10-{LONG}"], "terrain"),
    (["simulate", "--terrain", "hilly-1.0-10-10005"], "terrain"),
    (["simulate", "--shape", f"{LONG}x2"], "shape"),
    (["simulate", "--shape", f"2x{LONG}"], "shape"),
    (["simulate", "--seed", LONG], "seed"),
    (["simulate", "--duration", LONG], "duration"),
    (["simulate", "--duration", "1" * 400], "duration"),
    (["evaluate", "nowhere.json", "--validation", LONG], "validation"),
])
def test_long_numbers_on_the_command_line(args, field, capsys):
    err = run_main(capsys, *args)
    assert f"{field}=" in err


def test_training_on_a_validation_terrain_spelled_otherwise(tmp_path, capsys):
    for name in ("hilly-1-10-010000", "hilly-1.0-10-10005"):
        err = run_main(capsys, "evolve", "--out", str(tmp_path / "run"), "--terrain", name,
                       "--generations", "1", "--population", "2", "--duration", "0.1")
        assert "write it hilly-1-10-1000" in err


def test_shape_side_is_checked_before_it_is_read():
    with pytest.raises(SomiteError, match="at most 32 voxels a side"):
        Shape.parse(f"{LONG}x1")
    assert Shape.parse("3x2").grid_string() == "111/111"


@pytest.mark.parametrize("text", [f"x = {LONG}\n", "x = " + "[" * 5000 + "]" * 5000 + "\n",
                                  "x = [1,\n"])
def test_bad_toml_is_one_line_naming_the_file(tmp_path, capsys, text):
    config = tmp_path / "bad.toml"
    config.write_text(text)
    err = run_main(capsys, "evolve", "--out", str(tmp_path / "run"), "--config", str(config))
    assert f"config={str(config)!r}: not valid TOML" in err
    campaign = tmp_path / "campaign.toml"
    campaign.write_text(text)
    err = run_main(capsys, "campaign", "run", str(campaign), "--out", str(tmp_path / "c"))
    assert f"campaign={str(campaign)!r}: not valid TOML" in err


def test_long_integer_in_toml_is_named_briefly(tmp_path):
    from somite._io import read_toml

    path = tmp_path / "long.toml"
    path.write_text(f"x = {LONG}\n")
    with pytest.raises(SomiteError) as info:
        read_toml(path, "config")
    assert str(info.value).endswith("not valid TOML (an integer of more than 4300 digits)")


def test_long_integer_in_json_is_one_line(tmp_path, capsys):
    genome = tmp_path / "genome.json"
    genome.write_text(f'{{"version": {LONG}}}')
    err = run_main(capsys, "simulate", "--genome", str(genome))
    assert "not valid JSON" in err and "4300 digits" in err
    partition = tmp_path / "partition.json"
    partition.write_text(f'{{"version": {LONG}}}')
    from somite._io import read_json

    with pytest.raises(SomiteError) as info:
        read_json(partition, "partition")
    assert str(info.value).endswith("not valid JSON (an integer of more than 4300 digits)")


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    from somite.modules.library import export_module, provenance_of
    from somite.modules.module import cut
    from somite.sim.partition import Partition

    from .conftest import evolved

    folder = tmp_path_factory.mktemp("library")
    donor = evolved("worm", 72)
    halves = Partition.preset("worm-halves", "worm")
    module = cut(donor, halves).module("front")
    export_module(module, folder / "front.json",
                  provenance_of(module, donor, halves.grid_string(), "front.src", None))
    return folder


def test_a_long_placement_integer_is_one_line(tmp_path, library, capsys):
    """parse_placement reads X and Y with int(): cli.main's last resort makes it one line."""
    err = run_main(capsys, "assemble", str(library), "--place", f"front@{LONG},0",
                   "--out", str(tmp_path / "robot"))
    assert "more than 4300 digits" in err
    assert not (tmp_path / "robot").exists()


# -- strict JSON ----------------------------------------------------------------------------------


def _strict(text: str):
    def refuse(constant):
        raise AssertionError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_print_json_writes_null_for_nan_and_infinities(capsys):
    print_json({"a": math.nan, "b": [math.inf, 1.5, (-math.inf, 2)], "c": {"d": math.nan},
                "e": "NaN", "f": 3})
    assert _strict(capsys.readouterr().out) == {"a": None, "b": [None, 1.5, [None, 2]],
                                                "c": {"d": None}, "e": "NaN", "f": 3}


def test_simulate_json_is_strict(capsys):
    # Under 2 s, the tilt and height diagnostics are NaN (measured after the first 2 s).
    assert main(["simulate", "--duration", "0.5", "--json"]) == 0
    report = _strict(capsys.readouterr().out)
    assert report["max_tilt_deg"] is None and isinstance(report["velocity"], float)


# -- standard output closed, full or a closed pipe ------------------------------------------------


def _shell(command: str) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", f"set -o pipefail; {command}"], capture_output=True,
                          text=True, timeout=900)


def test_a_closed_pipe_ends_quietly():
    result = _shell(f"'{SOMITE}' campaign list | head -1")
    assert result.returncode in (0, 141) and result.stderr == "", result.stderr
    assert result.stdout.count("\n") == 1
    result = _shell(f"'{SOMITE}' simulate --help | head -c 1")
    assert result.returncode in (0, 141) and result.stderr == "", result.stderr


@pytest.mark.parametrize("redirect, why", [("> /dev/full", "No space left on device"),
                                           (">&-", "it is closed")])
def test_a_full_or_closed_stdout_is_one_line(redirect, why):
    result = _shell(f"'{SOMITE}' simulate --duration 0.1 --json {redirect}")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = [line for line in result.stderr.splitlines() if "warning" not in line]
    assert lines == [f"somite simulate: error: cannot write to standard output ({why})"]


def test_help_to_a_full_stdout_is_one_line():
    result = _shell(f"'{SOMITE}' --help > /dev/full")
    assert result.returncode == 1
    assert result.stderr == ("somite: error: cannot write to standard output (No space left on "
                             "device)\n")


def test_bad_input_with_stdout_closed_is_still_one_line(tmp_path):
    genome = tmp_path / "genome.json"
    genome.write_text(f'{{"version": {LONG}}}')
    result = _shell(f"'{SOMITE}' simulate --genome '{genome}' >&-")
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert "not valid JSON" in result.stderr
