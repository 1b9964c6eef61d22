"""Run directories under hostile use: locks, kills at any moment, foreign checkpoints, --force
(issue 10)."""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.experiments.lock import LOCK_NAME, RunLock
from somite.sim.body import Body

ARGS = ["evolve", "--shape", "worm", "--population", "10", "--generations", "30",
        "--duration", "2", "--seed", "5", "--checkpoint-every", "4", "--quiet"]


def rows(run: Path) -> list[dict]:
    with open(run / "log.csv") as handle:
        return [{k: v for k, v in r.items() if k != "elapsed_seconds"}
                for r in csv.DictReader(handle)]


def start(out: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "somite.cli", *ARGS, "--out", str(out),
                             *extra])


def wait_for(child: subprocess.Popen, ready, what: str) -> None:
    deadline = time.time() + 600
    while not ready():
        assert child.poll() is None, f"the run ended before {what}"
        assert time.time() < deadline, f"timed out waiting for {what}"
        time.sleep(0.002)


def log_rows(run: Path) -> int:
    try:
        return len((run / "log.csv").read_text().splitlines()) - 1
    except FileNotFoundError:
        return -1


@pytest.fixture(scope="module")
def whole(tmp_path_factory) -> Path:
    """The uninterrupted run every interrupted one must end up identical to."""
    out = tmp_path_factory.mktemp("whole") / "run"
    assert main([*ARGS, "--out", str(out)]) == 0
    return out


def assert_same_run(run: Path, whole: Path, *more: str) -> None:
    assert rows(run) == rows(whole)
    for name in ("best.json", "bests.jsonl", *more):
        assert (run / name).read_bytes() == (whole / name).read_bytes(), name


def test_second_process_is_refused_and_a_dead_holders_lock_is_taken_over(tmp_path, whole,
                                                                            capsys):
    run = tmp_path / "run"
    first = start(run)
    try:
        wait_for(first, lambda: log_rows(run) >= 3 and (run / "checkpoint.json").exists(),
                 "its first generations")
        # Frozen, the first run holds its lock for as long as the test needs.
        os.kill(first.pid, signal.SIGSTOP)
        before = {p.name: p.read_bytes() for p in run.iterdir() if p.name != LOCK_NAME}
        for extra in ((), ("--resume",), ("--force",)):
            capsys.readouterr()
            assert main([*ARGS, "--out", str(run), *extra]) == 2, extra
            err = capsys.readouterr().err  # of this process, a second one beside the first
            assert err.count("\n") == 1, err
            assert f"in use by process {first.pid} on {socket.gethostname()}" in err
            assert "started 20" in err
            assert {p.name: p.read_bytes() for p in run.iterdir()
                    if p.name != LOCK_NAME} == before
    finally:
        os.kill(first.pid, signal.SIGKILL)
        first.wait()
    assert first.returncode == -signal.SIGKILL
    assert json.loads((run / LOCK_NAME).read_text())["pid"] == first.pid  # left behind
    assert main([*ARGS, "--out", str(run), "--resume"]) == 0
    assert_same_run(run, whole)
    assert not (run / LOCK_NAME).exists()


def test_lock_in_one_process(tmp_path):
    with RunLock(tmp_path):
        with pytest.raises(SomiteError, match=f"in use by process {os.getpid()} "):
            RunLock(tmp_path).acquire()
    # A lock file whose writer is gone (no flock on it) is taken over.
    (tmp_path / LOCK_NAME).write_text('{"pid": 999999999, "host": "x", "started": "y"}')
    with RunLock(tmp_path) as lock:
        assert json.loads(lock.path.read_text())["pid"] == os.getpid()
    assert not (tmp_path / LOCK_NAME).exists()


def die_at_write(mode: str, kill_at: int) -> None:
    """Make this process SIGKILL itself at its ``kill_at``-th write: for ``replace``, an atomic
    write with its temporary file written and the rename not done; for ``append``, an append
    to log.csv or bests.jsonl half-way through its line."""
    import somite.experiments.runner as runner

    count = [0]

    def due() -> bool:
        count[0] += 1
        return count[0] == kill_at

    real_replace, real_open = os.replace, open

    def replace(source, target):
        if due():
            os.kill(os.getpid(), signal.SIGKILL)
        real_replace(source, target)

    class Torn:
        def __init__(self, handle):
            self.handle = handle

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.handle.close()

        def write(self, text):
            if due():
                self.handle.write(text[: len(text) // 2])
                self.handle.flush()
                os.kill(os.getpid(), signal.SIGKILL)
            return self.handle.write(text)

    def append_open(path, mode="r", *args, **kwargs):
        handle = real_open(path, mode, *args, **kwargs)
        return Torn(handle) if "a" in mode else handle

    if mode == "replace":
        os.replace = replace
    else:
        runner.open = append_open  # the run's appends to log.csv and bests.jsonl


def killed_run(mode: str, kill_at: int, argv: list[str]) -> int:
    """``somite ARGV`` in a child process that dies at its ``kill_at``-th write
    (:func:`die_at_write`); its exit code, or minus the signal that ended it. The child is
    forked, not a new interpreter: it starts with this process's imports and loaded kernels
    (a new one paid 1-2 s for them, some 40 times in this module)."""
    pid = os.fork()
    if pid == 0:  # the child: never back into pytest, whatever happens
        code = 70
        try:
            die_at_write(mode, kill_at)
            code = main(argv)
        finally:
            os._exit(code)
    return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])


SHORT = ["evolve", "--shape", "worm", "--population", "6", "--generations", "3",
         "--duration", "2", "--seed", "2", "--checkpoint-every", "2", "--quiet"]


def kill_at_each_write(tmp_path: Path, mode: str, args: list[str], *more: str) -> int:
    """Kill a run of ``args`` at each of its writes in turn: each atomic write (the first: the
    manifest, before any checkpoint) between its temporary file and its rename, or each append
    to log.csv and bests.jsonl half-way through its line. ``--resume`` must end in the
    uninterrupted run's files (and ``more``), temporary files gone. Returns the number of the
    first write that was not reached (the run went through)."""
    whole = tmp_path / "whole"
    assert main([*args, "--out", str(whole)]) == 0
    kill_at = 0
    while True:
        kill_at += 1
        run = tmp_path / f"killed-{kill_at}"
        returncode = killed_run(mode, kill_at, [*args, "--out", str(run)])
        if returncode == 0:
            return kill_at
        assert returncode == -signal.SIGKILL
        if mode == "replace":
            assert any(p.name.endswith(".tmp") for p in run.iterdir())
        assert main([*args, "--out", str(run), "--resume"]) == 0, kill_at
        assert_same_run(run, whole, *more)
        assert sorted(p.name for p in run.iterdir()) == sorted(p.name for p in whole.iterdir())


@pytest.mark.parametrize("mode", ["replace", "append"])
def test_a_kill_at_any_file_write_resumes_to_the_same_run(tmp_path, mode):
    # replace: manifest, config, physics, log, bests, then best.json and checkpoint at 0, 2
    # and 3; append: a log row and a best genome for each of generations 0 to 3.
    assert kill_at_each_write(tmp_path, mode, SHORT) == (12 if mode == "replace" else 9)


@pytest.mark.parametrize("mode", ["replace", "append"])
def test_a_kill_at_any_file_write_of_reoptimize_resumes_to_the_same_result(tmp_path, mode):
    genome = initial_genome(Body.build("worm"), np.random.default_rng(4))
    start = str(genome.save(tmp_path / "start.json"))
    args = ["reoptimize", start, "--donors", start, "--population", "4", "--generations",
            "2", "--duration", "1", "--validation", "1", "--seed", "2", "--checkpoint-every",
            "2", "--quiet"]
    # replace: manifest, config, physics, log, bests, best.json and checkpoint at 0 and 2,
    # then the manifest with transfer.csv and transfer.csv; append: generations 0 to 2.
    count = kill_at_each_write(tmp_path, mode, args, "transfer.csv")
    assert count == (12 if mode == "replace" else 7)


def test_a_kill_as_soon_as_the_directory_exists_resumes(tmp_path):
    whole = tmp_path / "whole"
    assert main([*SHORT, "--out", str(whole)]) == 0
    run = tmp_path / "run"
    child = subprocess.Popen([sys.executable, "-m", "somite.cli", *SHORT, "--out", str(run)])
    wait_for(child, run.exists, "the directory")
    child.kill()
    assert child.wait() == -signal.SIGKILL
    assert not (run / "checkpoint.json").exists()
    assert main([*SHORT, "--out", str(run), "--resume"]) == 0
    assert_same_run(run, whole)


def test_resume_with_more_generations_updates_config(tmp_path):
    run = tmp_path / "run"
    assert main([*SHORT, "--out", str(run)]) == 0
    assert main([*SHORT, "--out", str(run), "--resume", "--generations", "5"]) == 0
    assert json.loads((run / "config.json").read_text())["generations"] == 5
    assert [r["generation"] for r in rows(run)] == [str(g) for g in range(6)]


def files(run: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in run.iterdir()}


def refused(run: Path, capsys, message: str) -> None:
    before = files(run)
    assert main([*SHORT, "--out", str(run), "--resume"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert files(run) == before


def test_checkpoint_of_another_run_or_generation_is_refused(tmp_path, capsys):
    run, other = tmp_path / "run", tmp_path / "other"
    assert main([*SHORT, "--out", str(run)]) == 0
    own = (run / "checkpoint.json").read_text()
    for variation in (["--shape", "biped"], ["--seed", "3"], ["--sensors", "none"]):
        assert main([*SHORT, *variation, "--out", str(other), "--force"]) == 0
        capsys.readouterr()  # the 2 s episodes' warning (within the transient)
        (run / "checkpoint.json").write_text((other / "checkpoint.json").read_text())
        refused(run, capsys, "belongs to another run")
    state = json.loads(own)
    for generation in (-5, 4, 10**6, 1.5, "2", None):
        (run / "checkpoint.json").write_text(json.dumps({**state, "generation": generation}))
        refused(run, capsys, f"checkpoint.generation={generation!r}: log.csv holds "
                "generations 0 to 3")
    (run / "checkpoint.json").write_text(json.dumps({**state, "version": 2}))
    refused(run, capsys, "version 2 cannot be resumed")
    (run / "checkpoint.json").write_text("[" * 200_000 + "]" * 200_000)
    refused(run, capsys, "damaged checkpoint")
    (run / "checkpoint.json").write_text(own)
    assert main([*SHORT, "--out", str(run), "--resume"]) == 0


def test_force_deletes_only_what_the_manifest_lists(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text("my own notes\n")
    assert main([*SHORT, "--out", str(run)]) == 2
    assert "holds a run already" in capsys.readouterr().err
    for extra in (["--force"], ["--force", "--seed", "9"]):
        refused_force(run, capsys, extra, "holds config.json, which is not a file of the run")
    (run / "config.json").unlink()
    assert main([*SHORT, "--out", str(run)]) == 0
    assert main([*SHORT, "--out", str(run), "--force", "--seed", "9"]) == 0
    capsys.readouterr()  # the 2 s episodes' warnings (within the transient)
    (run / "notes.txt").write_text("mine\n")
    refused_force(run, capsys, [], "holds notes.txt, which is not a file of the run")
    (run / "notes.txt").unlink()
    (run / "best.json").unlink()
    (run / "best.json").mkdir()  # a run file that is a folder: nothing deleted, no crash
    refused_force(run, capsys, [], "holds best.json, which is not a file of the run")
    (run / "best.json").rmdir()
    (run / "manifest.json").write_text('{"files": ["notes.txt"]}')
    refused_force(run, capsys, [], "holds a manifest.json that is not a somite run's")


def refused_force(run: Path, capsys, extra: list[str], message: str) -> None:
    before = files_and_folders(run)
    assert main([*SHORT, "--out", str(run), "--force", *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert files_and_folders(run) == before


def files_and_folders(run: Path) -> dict[str, bytes | None]:
    return {p.name: p.read_bytes() if p.is_file() else None for p in run.iterdir()}


@pytest.mark.parametrize("text", ["[]", '{"duration": "long"}', '{"duration": 1e999}',
                                  "[" * 100_000, '"\\ud800"', "{"])
def test_damaged_config_json_is_refused_on_resume(tmp_path, capsys, text):
    run = tmp_path / "run"
    assert main([*SHORT, "--out", str(run)]) == 0
    capsys.readouterr()  # the 2 s episodes' warning (within the transient)
    (run / "config.json").write_text(text)
    before = files(run)
    assert main(["evolve", "--out", str(run), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("config" in err or "duration" in err), err
    assert files(run) == before


def test_an_error_after_the_progress_bar_started_is_the_only_output(tmp_path, capsys):
    assert main(["evolve", "--shape", "worm", "--modules", "biped-legs", "--omega", "10",
                 "--generations", "1", "--out", str(tmp_path / "run")]) == 2
    out, err = capsys.readouterr()
    assert err.count("\n") == 1 and "generation" not in out + err, (out, err)
    assert not (tmp_path / "run").exists()


def test_a_killed_reoptimize_force_leaves_no_old_transfer_csv(tmp_path):
    run = tmp_path / "run"
    assert main([*SHORT, "--out", str(run)]) == 0
    args = ["reoptimize", str(run), "--generations", "1", "--population", "4", "--duration",
            "1", "--validation", "1", "--quiet", "--out", str(tmp_path / "re")]
    assert main(args) == 0
    assert (tmp_path / "re" / "transfer.csv").is_file()
    assert "transfer.csv" in json.loads((tmp_path / "re" / "manifest.json").read_text())["files"]
    assert killed_run("replace", 1, [*args, "--force"]) == -signal.SIGKILL
    assert not (tmp_path / "re" / "transfer.csv").exists()
    assert main([*args, "--resume"]) == 0
    assert (tmp_path / "re" / "transfer.csv").is_file()


def test_a_left_over_output_check_file_is_the_run_s_own(tmp_path):
    """A kill between creating and deleting the file that tries an output folder leaves
    ``.somite-check.*``: neither --force nor --resume stumbles on it, --resume removes it."""
    run = tmp_path / "run"
    assert main([*SHORT, "--out", str(run)]) == 0
    (run / ".somite-check.abc123").write_text("")
    assert main([*SHORT, "--out", str(run), "--force"]) == 0
    (run / ".somite-check.abc123").write_text("")
    assert main([*SHORT, "--out", str(run), "--resume", "--generations", "4"]) == 0
    assert not (run / ".somite-check.abc123").exists()
