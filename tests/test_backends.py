"""Every registered backend runs the CPU's episode code (cuda checked on numba-cuda's
simulator, as CI has no GPU), and lockstep runs write the logs their solo runs write."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from somite import evolve_lockstep
from somite.cli import main
from somite.experiments.config import resolve
from somite.experiments.runner import evolve
from somite.sim.config import pack_params, preset
from somite.sim.sensors import noise_table
from somite.tasks.backends import BACKENDS, check_backend, cuda_unavailable
from somite.tasks.episode import Trace, new_trace
from somite.tasks.lanes import run_batch
from somite.tasks.locomotion import outcomes
from somite.tasks.stepper import Episode

from .backend_batch import CASES, batch, run_cases, run_elsewhere
from .conftest import expect_error


def _gap(a, b) -> float:
    # Equal infinities, and NaN in both at the same place (diagnostics not measured yet), count
    # as equal; NaN in one only as infinitely far.
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore"):  # inf - inf, masked by ``same``
        far = np.abs(a - b)
    return float(np.nan_to_num(np.where(same, 0.0, far), nan=np.inf).max())


def _backend_traces(name: str, tmp_path: Path) -> dict[str, Trace]:
    """The batch's traces on backend ``name``: here for the CPU's; in a process of its own
    under numba-cuda's simulator for the others (CI has no GPU)."""
    if name == "cpu":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps
            return run_cases(name)
    out = run_elsewhere("tests.backend_batch", name, tmp_path / f"{name}.npz")
    with np.load(out) as saved:
        if "terrain_fields" in saved:
            assert bool(saved["terrain_fields"])
        return {p: Trace(**{f: saved[f"{p}.{f}"] for f in Trace._fields}) for p, _ in CASES}


@pytest.mark.parametrize("name", list(BACKENDS))
def test_every_backend_gives_the_cpu_kernels_numbers(name, tmp_path):
    """The CPU kernel called directly against the backend run through the registry, and
    against the Python stepper (somite.Episode), which runs the same start / control_step code
    and must agree bit for bit."""
    others = _backend_traces(name, tmp_path)
    bodies, graphs, terrains, system, ctrl, seeds = batch()
    for preset_name, duration in CASES:
        config = preset(preset_name, duration=duration)
        cpu = new_trace(2, config.n_steps, system, True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps
            run_batch(system, ctrl, pack_params(config), noise_table(config), seeds,
                      config.n_steps, cpu)
            stepped = Episode(graphs, terrains, config, seeds.tolist(), record=True,
                              bodies=bodies).run()
        other = others[preset_name]
        assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(cpu, stepped))
        if preset_name == "paper":  # a block on the ground: the contacts are compared too
            assert cpu.contact.any(axis=2).sum(axis=1).min() > 0
        assert cpu.status.tolist() == other.status.tolist() == [0, 0]
        velocities = [o.velocity for o in outcomes(cpu, config)]
        assert velocities == pytest.approx([o.velocity for o in outcomes(other, config)],
                                           abs=1e-9)
        # Two different robots (v_x is 0 for both over a run shorter than the transient).
        assert abs(cpu.min_area[0] - cpu.min_area[1]) > 1e-6
        assert np.abs(cpu.com - other.com).max() < 1e-9
        gaps = {f: _gap(getattr(cpu, f), getattr(other, f))
                for f in ("max_speed", "min_area", "diagnostics", "non_finite")}
        assert all(gap < 1e-9 for gap in gaps.values()), gaps


@pytest.mark.parametrize("name", list(BACKENDS))
def test_every_backend_is_in_the_command_lines_help(name, capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"{name}, {BACKENDS[name].help}" in text
    assert "{" + ",".join(BACKENDS) + "}" in text


def test_unknown_or_unavailable_backend_is_a_one_line_error(capsys):
    expect_error("backend", lambda: check_backend("gpu"))
    if cuda_unavailable() is None:
        pytest.skip("a CUDA GPU (or the simulator) is available here")
    expect_error("backend", lambda: check_backend("cuda"))
    for command in (["simulate", "--duration", "0.1"], ["bench", "--robots", "4"]):
        assert main([*command, "--backend", "cuda"]) == 2
        err = capsys.readouterr().err.strip()
        assert "error: backend='cuda': " in err and "\n" not in err


def _run_files(path: Path) -> dict:
    """A run directory's files, without the wall-clock times they record."""
    log = [line.split(",") for line in (path / "log.csv").read_text().splitlines()]
    timed = log[0].index("elapsed_seconds")
    checkpoint = json.loads((path / "checkpoint.json").read_text())
    checkpoint.pop("elapsed_seconds")
    return {
        "log": [row[:timed] + row[timed + 1:] for row in log],
        "bests": (path / "bests.jsonl").read_text(),
        "best": (path / "best.json").read_text(),
        "checkpoint": checkpoint,
    }


def test_lockstep_runs_write_what_solo_runs_write(tmp_path):
    small = {"population": 5, "generations": 3, "duration": 0.5, "validate_every": 2}
    configs = [
        resolve({**small, "seed": 3}),
        resolve({**small, "seed": 4, "shape": "biped"}),
        resolve({**small, "seed": 5, "generations": 1, "duration": 0.4}),
    ]
    for i, config in enumerate(configs):
        evolve(config, tmp_path / f"solo{i}")
    eas = evolve_lockstep([(c, tmp_path / f"together{i}") for i, c in enumerate(configs)])
    assert [ea.generation for ea in eas] == [3, 3, 1]
    for i in range(len(configs)):
        solo = _run_files(tmp_path / f"solo{i}")
        assert _run_files(tmp_path / f"together{i}") == solo
        assert len(solo["log"]) == configs[i].generations + 2
    assert _run_files(tmp_path / "together0") != _run_files(tmp_path / "together1")
