"""The Python API checked like the command line (issue 46): each finding of the fourth probe,
reproduced, now a one-line SomiteError (a ValueError, or a TypeError too for a wrong type)
that names the argument and the value, raised before anything is built or simulated."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

import somite
from somite.brain.compile import compile_genome
from somite.brain.controllers import GraphArrays
from somite.cli import main
from somite.errors import SomiteError, SomiteTypeError
from somite.evolution.operators import initial_genome
from somite.limits import MAX_EVALUATIONS, MAX_STEPPED, MAX_VALIDATION
from somite.sim.config import BOUNDS, CHOICES, SimConfig

from .conftest import expect_error

TINY = SimConfig(duration=1 / 60)


@pytest.fixture(scope="module")
def genomes(worm, biped):
    rng = np.random.default_rng(46)
    return initial_genome(worm, rng), initial_genome(biped, rng)


refused = expect_error
"""``refused(field, build[, kind])``: ``build()`` raises a one-line SomiteError (or ``kind``)
naming ``field`` first."""


# -- 1. a body/controller mismatch never reaches the kernel -----------------------------------


def test_a_controller_on_another_body_is_refused_before_the_kernel(genomes, worm, biped,
                                                                  monkeypatch):
    from somite.tasks import locomotion

    def no_kernel(*args, **kwargs):
        raise AssertionError("the batch was compiled for the kernel")

    monkeypatch.setattr(locomotion, "compile_system", no_kernel)
    g_worm, g_biped = genomes
    # The probe's segfault: a worm's controller stepped on a biped, and the reverse.
    message = refused("controllers[0]", lambda: somite.Episode(
        [compile_genome(g_worm)], "flat", TINY, bodies=[biped]))
    assert "111111/111111" in message and "1111/1111/1001" in message
    refused("controllers[0]", lambda: somite.Episode([compile_genome(g_biped)], "flat", TINY,
                                                     bodies=[worm]))
    refused("bodies[0]", lambda: somite.Episode([g_worm], "flat", TINY, bodies=[biped]))
    flat = somite.parse_terrain("flat")
    refused("controllers[1]", lambda: somite.simulate_batch(
        [worm, worm], [flat, flat], [compile_genome(g_worm), compile_genome(g_biped)], TINY))


def test_a_graph_without_its_body_is_checked_against_the_body_it_is_given(genomes, worm,
                                                                         biped):
    arrays = compile_genome(genomes[0])  # the worm's: voxels and readings past the biped's
    unknown = GraphArrays(arrays.node_kind, arrays.node_ref, arrays.src, arrays.dst,
                          arrays.weight, arrays.bias)
    assert "biped" not in refused("controllers[0]", lambda: somite.Episode(
        [unknown], "flat", TINY, bodies=[biped]))
    own = compile_genome(genomes[0])
    past = GraphArrays(own.node_kind, own.node_ref, own.src, own.dst + 1000, own.weight,
                       own.bias)
    assert "edges" in refused("controllers[0]", lambda: somite.Episode(
        [past], "flat", TINY, bodies=[worm]))


# -- 2. every SimConfig number bounded, in one table --------------------------------------------


def test_every_field_of_simconfig_is_in_the_table():
    names = {f.name for f in fields(SimConfig)}
    assert names == set(BOUNDS) | set(CHOICES) | {"lidar_angles"}


@pytest.mark.parametrize("name", sorted(BOUNDS))
def test_each_number_is_bounded_and_typed(name):
    bound = BOUNDS[name]
    refused(name, lambda: SimConfig(**{name: bound.high * 2 + 1}))
    refused(name, lambda: SimConfig(**{name: bound.low - 1}))
    refused(name, lambda: SimConfig(**{name: str(bound.high)}), SomiteTypeError)
    refused(name, lambda: SimConfig(**{name: True}), SomiteTypeError)
    if bound.integer:
        refused(name, lambda: SimConfig(**{name: 2.0}), SomiteTypeError)
    else:
        refused(name, lambda: SimConfig(**{name: math.inf}))
        refused(name, lambda: SimConfig(**{name: 10**400}))
    # The bounds are not the defaults' neighbourhood: the defaults pass.
    assert getattr(SimConfig(**{name: getattr(SimConfig(), name)}), name) == getattr(
        SimConfig(), name)


@pytest.mark.parametrize(("name", "value"), [
    ("substeps", 2**40), ("velocity_iterations", 2**31), ("position_iterations", 2**31),
    ("touch_window", 10**12), ("velocity_window", 10**12), ("start_gap", 1e300),
])
def test_the_probe_values_that_hung_or_crashed_are_refused(name, value):
    refused(name, lambda: SimConfig(**{name: value}))
    refused(name, lambda: somite.preset("paper", **{name: value}))


def test_text_fields_and_lidar_angles_are_checked():
    refused("hidden_activation", lambda: SimConfig(hidden_activation=3), SomiteTypeError)
    refused("noise_stream", lambda: SimConfig(noise_stream="java"))
    refused("lidar_angles", lambda: SimConfig(lidar_angles=(0.0,) * 4))
    refused("lidar_angles[2]", lambda: SimConfig(lidar_angles=(0.0, 0.0, "x", 0.0, 0.0)),
            SomiteTypeError)
    refused("lidar_angles[0]", lambda: SimConfig(lidar_angles=(7.0, 0, 0, 0, 0)))
    refused("preset", lambda: somite.preset(["paper"]), SomiteTypeError)
    # NumPy numbers are read as Python's, so that config.json stays plain JSON.
    config = SimConfig(duration=np.float32(2.0), substeps=np.int64(2),
                       lidar_angles=[0.1, 0, 0, 0, np.float64(-0.1)])
    assert type(config.duration) is float and type(config.substeps) is int
    assert config.lidar_angles == (0.1, 0.0, 0.0, 0.0, -0.1)
    json.dumps(config.to_dict(), allow_nan=False)


# -- 3. tell() takes real, finite fitness (NaN: a failed episode) -----------------------------


@pytest.fixture
def asked(worm):
    ea = somite.GraphEA(worm, population=4, seed=0)
    return ea, ea.ask()


@pytest.mark.parametrize(("value", "kind"), [
    (math.inf, SomiteError), (-math.inf, SomiteError), (10**400, SomiteError),
    ("0.1", SomiteTypeError), (None, SomiteTypeError), (True, SomiteTypeError),
    (1j, SomiteTypeError), (np.complex128(1), SomiteTypeError),
])
def test_tell_refuses_fitness_that_is_not_a_finite_real(asked, value, kind):
    ea, genomes = asked
    refused("fitness[1]", lambda: ea.tell(genomes, [0.1, value, 0.2, 0.3]), kind)
    assert ea.generation == -1 and ea.log == []  # nothing told: ask's genomes still pending
    ea.tell(genomes, [0.1, math.nan, 0.2, 0.3])
    assert ea.best_fitness == 0.3
    assert json.loads(json.dumps(ea.state(), allow_nan=False))["fitness"][1] is None


@pytest.mark.parametrize("value", [-3, 2.9, 10**30, True, "1"])
def test_tell_refuses_a_non_finite_count_that_is_not_one(asked, value):
    ea, genomes = asked
    refused("non_finite", lambda: ea.tell(genomes, [0.1] * 4, non_finite=value))
    assert ea.tell(genomes, [0.1] * 4, non_finite=3)["non_finite_episodes"] == 3


def test_tell_refuses_the_wrong_number_and_kind_of_fitness(asked):
    ea, genomes = asked
    refused("fitness", lambda: ea.tell(genomes, [0.1] * 3))
    refused("fitness", lambda: ea.tell(genomes, "0.1 0.2"), SomiteTypeError)
    refused("fitness", lambda: ea.tell(genomes, np.zeros((2, 2))))
    refused("genomes", lambda: ea.tell(None, [0.1] * 4), SomiteTypeError)


# -- 4. signals ---------------------------------------------------------------------------------


def test_sigterm_while_unwinding_from_ctrl_c_is_one_line(monkeypatch, capsys):
    """The probe's SIGINT then SIGTERM within ~10 ms: the TERM came while the "interrupted"
    line was printed and raised there, a second traceback. Now the first signal wins."""
    from somite.commands import simulate

    def killed(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            raise AssertionError("SIGINT did not interrupt the command")
        finally:
            os.kill(os.getpid(), signal.SIGTERM)  # handled during the unwinding: ignored

    monkeypatch.setattr(simulate, "run", killed)
    before = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
    assert main(["simulate", "--duration", "1"]) == 130
    assert capsys.readouterr().err == "somite simulate: interrupted\n"
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_an_interrupt_does_not_wait_for_the_helper_threads():
    """A kernel under way on a helper thread (its first compile takes minutes) cannot be
    stopped: spread() re-raises Ctrl-C in the calling thread without waiting for it."""
    import numba

    from somite._threads import spread

    if numba.get_num_threads() < 2:
        pytest.skip("needs two threads")
    started, release, finished = threading.Event(), threading.Event(), threading.Event()

    def task(i):
        if threading.current_thread() is threading.main_thread():
            started.wait(60)  # the helper has the other task
            raise KeyboardInterrupt
        started.set()
        release.wait(60)
        finished.set()

    with pytest.raises(KeyboardInterrupt):
        spread(task, 2)
    assert not finished.is_set()  # spread came back while the helper was still busy
    release.set()
    assert finished.wait(60)


# -- 5. environment -----------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["0", "-1", "abc", "1.5", "100000", ""])
def test_numba_threads_out_of_range_is_one_line(value):
    from somite.commands._environment import check_environment

    refused("NUMBA_NUM_THREADS", lambda: check_environment({"NUMBA_NUM_THREADS": value}))
    check_environment({"NUMBA_NUM_THREADS": "2"})


@pytest.mark.parametrize(("variable", "value", "args"), [
    ("NUMBA_NUM_THREADS", "0", ["simulate", "--duration", "0.1"]),
    ("MPLBACKEND", "nonsense", ["plot", "nowhere"]),
])
def test_a_bad_environment_is_one_line_on_the_command_line(variable, value, args):
    env = {**os.environ, variable: value}
    child = subprocess.run([sys.executable, "-m", "somite.cli", *args], env=env,
                           capture_output=True, text=True, timeout=900)
    assert child.returncode == 2, child.stderr
    assert child.stderr.startswith(f"somite: error: {variable}={value!r}: ")
    assert child.stderr.count("\n") == 1 and "Traceback" not in child.stderr


# -- 6. documented limits and types, in the API -------------------------------------------------


def test_documented_limits_hold_in_the_api(genomes, worm):
    g = genomes[0]
    refused("evaluations", lambda: somite.Locomotion(evaluations=MAX_EVALUATIONS + 1))
    refused("validation", lambda: somite.Locomotion(validation=MAX_VALIDATION + 1))
    refused("terrains", lambda: somite.evaluate_genomes([g], ["flat"] * (MAX_VALIDATION + 1),
                                                        TINY))
    refused("robots", lambda: somite.Episode([somite.Zero()] * (MAX_STEPPED + 1), "flat", TINY,
                                             bodies=[worm] * (MAX_STEPPED + 1)))
    refused("duration", lambda: somite.simulate(g, duration=601.0))


@pytest.mark.parametrize(("field", "call"), [
    ("duration", lambda g, b: somite.simulate(g, duration="1")),
    ("duration", lambda g, b: somite.simulate(g, duration="1", sim=TINY)),
    ("config", lambda g, b: somite.Episode([g], "flat", {"duration": 1.0})),
    ("bodies[0]", lambda g, b: somite.Episode([somite.Zero()], "flat", TINY, bodies=["worm"])),
    ("seeds", lambda g, b: somite.Episode([g], "flat", TINY, seeds=["7"])),
    ("seeds", lambda g, b: somite.Episode([g], "flat", TINY, seeds=[2.7])),
    ("seeds", lambda g, b: somite.Episode([g], "flat", TINY, seeds=-1)),
    ("record", lambda g, b: somite.Episode([g], "flat", TINY, record="yes")),
    ("terrains", lambda g, b: somite.Episode([g], 5, TINY)),
    ("genomes[0]", lambda g, b: somite.evaluate_genomes(["g"], ["flat"], TINY)),
    ("config", lambda g, b: somite.evaluate_genomes([g], ["flat"], {"duration": 1})),
    ("shape", lambda g, b: somite.Body.build(None)),
    ("sensors", lambda g, b: somite.Body.build("worm", sensors=[1])),
    ("robot", lambda g, b: somite.simulate(5, body=b)),
    ("body", lambda g, b: somite.simulate(somite.Zero(), body="worm")),
    ("seed", lambda g, b: somite.simulate(g, seed=2.0)),
    ("backend", lambda g, b: somite.simulate(g, backend=None)),
    ("terrain", lambda g, b: somite.Locomotion(terrain=3)),
    ("sim", lambda g, b: somite.Locomotion(sim={"duration": 1.0})),
    ("rng", lambda g, b: somite.Locomotion(duration=1.0).evaluate([g], rng=3)),
    ("genomes", lambda g, b: somite.Locomotion(duration=1.0).evaluate(g, rng=None)),
    ("start", lambda g, b: somite.GraphEA(b, start="best.json")),
    ("seed", lambda g, b: somite.GraphEA(b, seed="1")),
])
def test_a_wrong_argument_is_named(genomes, worm, field, call):
    with pytest.raises(SomiteError) as info:
        call(genomes[0], worm)
    assert str(info.value).startswith(f"{field}"), str(info.value)
    assert isinstance(info.value, ValueError)


def test_terrain_names_are_read_where_terrains_are_asked_for(genomes):
    """``evaluate_genomes([g], ["flat"], cfg)`` ended in an AttributeError: names are now
    read as ``simulate`` and ``Episode`` read them."""
    assert somite.evaluate_genomes([genomes[0]], ["flat"], TINY).shape == (1, 1)


def test_step_takes_real_numbers_only(genomes):
    episode = somite.Episode([genomes[0]], "flat", SimConfig(duration=3 / 60))
    width = episode.n_voxels
    refused("actuation", lambda: episode.step([["0.5"] * width]), SomiteTypeError)
    refused("actuation", lambda: episode.step(np.full((1, width), 0.5 + 0j)), SomiteTypeError)
    refused("actuation", lambda: episode.step("0.5"), SomiteTypeError)
    refused("actuation", lambda: episode.step([[0.5] * (width - 1)]))
    assert episode.k == 0
    episode.step(np.full((1, width), 0.5, dtype=np.float32))
    assert episode.k == 1


# -- 7. start in an evolve configuration --------------------------------------------------------


def test_start_in_an_evolve_toml_is_refused(tmp_path, capsys):
    config = tmp_path / "c.toml"
    config.write_text('start = "/dev/zero"\n')
    out = tmp_path / "run"
    assert main(["evolve", "--config", str(config), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "config.start='/dev/zero'" in err
    assert not out.exists()


def test_start_named_without_a_genome_is_refused_before_writing(tmp_path):
    config = somite.resolve({"shape": "worm", "population": 2, "generations": 0,
                             "duration": 1.0, "start": "best.json"})
    expect_error("start", lambda: somite.evolve(config, tmp_path / "run"))
    assert not (tmp_path / "run" / "config.json").exists()
    assert not (tmp_path / "run" / "log.csv").exists()


# -- 8. strict JSON readers ---------------------------------------------------------------------


def test_a_key_twice_is_refused(genomes):
    text = genomes[0].to_compact()
    # The probe's: a trailing "edges": [] read last-wins dropped every edge.
    message = expect_error("genome", lambda: somite.Genome.from_compact(text[:-1]
                                                                       + ',"edges":[]}'))
    assert "'edges' appears twice" in message


@pytest.mark.parametrize(("where", "field"), [
    (lambda d: d, "colour"),
    (lambda d: d["body"], "body.colour"),
    (lambda d: d["nodes"][0], "nodes[0].colour"),
    (lambda d: d["edges"][0], "edges[0].colour"),
])
def test_an_unknown_key_is_refused(genomes, where, field):
    data = genomes[0].to_dict()
    where(data)["colour"] = "x" * 10_000
    message = expect_error(field, lambda: somite.Genome.from_dict(data))
    assert "unknown key" in message and len(message) < 300


def test_module_files_are_read_strictly(made_run, tmp_path, capsys):
    from somite.modules.library import load_module

    out = tmp_path / "back.json"
    assert main(["module", "export", str(made_run), "--partition", "worm-halves", "--module",
                 "back", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    load_module(out)
    for change, seen in (
        (lambda d: d.update(extra=1), "extra"),
        (lambda d: d["nodes"][0].update(colour=1), "nodes[0].colour"),
        (lambda d: d["voxels"][0].update(colour=1), "voxels[0].colour"),
    ):
        edited = json.loads(json.dumps(data))
        change(edited)
        out.write_text(json.dumps(edited))
        with pytest.raises(SomiteError, match=re.escape(f"{seen}=")):
            load_module(out)
    out.write_text(json.dumps(data)[:-1] + ', "edges": []}')
    with pytest.raises(SomiteError, match="appears twice"):
        load_module(out)


# -- 9. a campaign task is done only with a whole done.json ------------------------------------


@pytest.mark.parametrize("text", ["[]", '{"task": "t"', "", "null", '"done"'])
def test_a_damaged_done_json_is_not_done(tmp_path, text):
    from somite.campaigns.directory import finished
    from somite.campaigns.layout import read_done

    (tmp_path / "t").mkdir()
    (tmp_path / "t" / "done.json").write_text(text)
    assert read_done(tmp_path / "t") is None
    assert not finished(tmp_path, {"id": "t", "path": "t"})
    record = {"task": "t", "elapsed_s": 1.0, "robot_control_steps": 5, "finished": "now"}
    (tmp_path / "t" / "done.json").write_text(json.dumps(record))
    assert read_done(tmp_path / "t") == record
    assert finished(tmp_path, {"id": "t", "path": "t"})


def test_errors_are_value_errors_and_type_errors():
    assert issubclass(SomiteError, ValueError) and issubclass(SomiteTypeError, TypeError)
    assert issubclass(SomiteTypeError, SomiteError)
    assert somite.SomiteError is SomiteError


# -- 9. --resume refuses before it writes -------------------------------------------------------


def _files(folder) -> dict:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def test_resume_refuses_an_unwritable_checkpoint_before_writing(made_run, tmp_path, capsys,
                                                                 monkeypatch):
    """The probe made checkpoint.json immutable (chattr +i): --resume rewrote config.json and
    appended to log.csv before it was refused. os.access is what sees the flag."""
    import shutil

    from somite._io import os as io_os

    run = tmp_path / "run"
    shutil.copytree(made_run, run)
    before = _files(run)
    real = io_os.access
    monkeypatch.setattr(io_os, "access", lambda path, mode, **kw: (
        False if str(path).endswith("checkpoint.json") else real(path, mode, **kw)))
    code = main(["evolve", "--resume", "--generations", "2", "--out", str(run), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "checkpoint.json" in err, err
    assert _files(run) == before


def test_resume_refuses_a_manifest_of_another_format(made_run, tmp_path, capsys):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(made_run, run)
    (run / "manifest.json").write_text(json.dumps({"format": "somite-genome", "files": []}))
    before = _files(run)
    code = main(["evolve", "--resume", "--generations", "2", "--out", str(run), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "not a somite run manifest" in err, err
    assert _files(run) == before


def test_report_names_a_finished_run_without_its_bests(made_run, tmp_path):
    """The report read a finished run whose bests.jsonl was deleted or cut as if whole."""
    import shutil

    from somite.campaigns.kinds import TASK_KINDS

    run = tmp_path / "run"
    shutil.copytree(made_run, run)
    assert TASK_KINDS["evolve"].read(run, {})["runs"].config["shape"] == "worm"
    (run / "bests.jsonl").write_text("")
    with pytest.raises(SomiteError, match="bests"):
        TASK_KINDS["evolve"].read(run, {})
    (run / "bests.jsonl").unlink()
    with pytest.raises(SomiteError, match="bests"):
        TASK_KINDS["evolve"].read(run, {})


@pytest.mark.parametrize("text", [
    "generation,training_velocity,validation_velocity,rho\n0,0.1,zero,0.5\n",
    "generation,training_velocity,validation_velocity,rho\n0,0.1,0.2\n",
    "generation,training_velocity,validation_velocity,rho\n0,0.1,0.2,0.3,0.4\n",
])
def test_a_garbled_transfer_csv_is_refused(tmp_path, text):
    from somite.campaigns.kinds.reoptimize import read_transfer

    (tmp_path / "transfer.csv").write_text(
        "generation,training_velocity,validation_velocity,rho\n0,0.1,nan,\n")
    assert read_transfer(tmp_path)[0]["rho"] is None or math.isnan(
        read_transfer(tmp_path)[0]["rho"])
    (tmp_path / "transfer.csv").write_text(text)
    with pytest.raises(SomiteError, match="transfer"):
        read_transfer(tmp_path)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="Linux's /proc")
def test_a_killed_reports_staging_folder_goes_at_the_next_report(tmp_path):
    """The probe killed a report and started it again at once: the killed process was not
    reaped yet (a zombie), so its hidden folder was taken for a live report's and stayed."""
    from somite.report.staging import _remove_abandoned

    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    staging = tmp_path / f".report.{child.pid}.0123abcd.new"
    staging.mkdir()
    _remove_abandoned(tmp_path)
    assert staging.is_dir()  # its report is running
    child.kill()
    while Path(f"/proc/{child.pid}/stat").read_text().split(") ")[1][:1] not in "ZX":
        threading.Event().wait(0.01)
    _remove_abandoned(tmp_path)  # killed, not yet reaped by its parent (this test)
    assert not staging.exists()
    child.wait()


def test_a_file_size_limit_stops_a_run_in_one_line_and_it_resumes(tmp_path, capsys):
    """Finding 9: under ``ulimit -f`` a run stops at the first write past the limit with one
    line naming the file (Python ignores SIGXFSZ, so the write fails, it does not kill), and
    what it left resumes to the end once the limit is gone."""
    import resource

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4000, 4000))

    run = tmp_path / "run"
    args = [sys.executable, "-m", "somite.cli", "evolve", "--shape", "worm", "--population", "4",
            "--generations", "3", "--duration", "1", "--validate-every", "0", "--out", str(run)]
    child = subprocess.run(args, preexec_fn=limited, capture_output=True, text=True, timeout=900)
    assert child.returncode == 2, child.stderr
    assert child.stderr.count("\n") == 1 and "(File too large)" in child.stderr, child.stderr
    # Resumed here, in a process without the limit.
    assert main(["evolve", "--resume", "--out", str(run)]) == 0, capsys.readouterr().err
    assert json.loads((run / "checkpoint.json").read_text())["generation"] == 3
