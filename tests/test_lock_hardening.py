"""A lock that cannot be fooled (issue 23): a symlinked lock file, a lock file deleted during
a run, a lock whose write failed, and commands that write into a running run's folder."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from somite.cli import main
from somite.errors import SomiteError
from somite.experiments import lock as lock_module
from somite.experiments.lock import LOCK_NAME, RunLock, is_run_folder, lock_if_run
from somite.experiments.runner import MANIFEST, RUN_FILES

RUN_MARKERS = (*RUN_FILES, MANIFEST)


@pytest.fixture
def run(made_run, tmp_path, capsys) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(made_run, copy)
    capsys.readouterr()  # the 1 s episode's warning about the transient
    return copy


def contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())
            if p.name != LOCK_NAME}


def refused(capsys, argv: list[str], *words: str) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, (out, err)
    for word in words:
        assert word in err, err
    return err


# 1. A symbolic link (or anything not a regular file) in the lock's place.

def test_a_symlinked_lock_is_refused_and_its_target_untouched(tmp_path):
    run_dir, outside = tmp_path / "run", tmp_path / "outside"
    run_dir.mkdir()
    outside.mkdir()
    target = outside / "precious.txt"
    target.write_text("keep me\n")
    (run_dir / LOCK_NAME).symlink_to(target)
    with pytest.raises(SomiteError) as caught:
        RunLock(run_dir).acquire()
    assert str(caught.value) == (f"out={str(run_dir)!r}: its {LOCK_NAME} is a symbolic link "
                                 "(or not a regular file); remove it")
    assert target.read_text() == "keep me\n"
    # A dangling link is not followed either: nothing is created at its target.
    (run_dir / LOCK_NAME).unlink()
    (run_dir / LOCK_NAME).symlink_to(outside / "created.txt")
    with pytest.raises(SomiteError, match="is a symbolic link"):
        RunLock(run_dir).acquire()
    assert sorted(p.name for p in outside.iterdir()) == ["precious.txt"]
    # And the folder is not left locked: once the link is gone, the lock is taken.
    (run_dir / LOCK_NAME).unlink()
    with RunLock(run_dir) as lock:
        assert lock.held


@pytest.mark.parametrize("kind", ["folder", "fifo", "hard link"])
def test_a_lock_that_is_not_a_regular_file_of_its_own_is_refused(tmp_path, kind):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    other = tmp_path / "other.txt"
    other.write_text("another file\n")
    if kind == "folder":
        (run_dir / LOCK_NAME).mkdir()
    elif kind == "fifo":
        os.mkfifo(run_dir / LOCK_NAME)
    else:
        os.link(other, run_dir / LOCK_NAME)
    with pytest.raises(SomiteError) as caught:
        RunLock(run_dir).acquire()
    message = str(caught.value)
    assert message.startswith(f"out={str(run_dir)!r}: its {LOCK_NAME} ") and "remove it" in message
    assert "\n" not in message
    assert other.read_text() == "another file\n"


def test_evolve_into_a_run_with_a_symlinked_lock_is_refused(tmp_path, capsys):
    target = tmp_path / "target"
    target.write_text("x")
    out = tmp_path / "run"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(target)
    refused(capsys, ["evolve", "--shape", "worm", "--population", "4", "--generations", "1",
                     "--duration", "1", "--out", str(out), "--quiet"], "symbolic link")
    assert target.read_text() == "x"


# 2. Deleting the lock file does not release the lock.

def test_deleting_the_lock_file_does_not_release_the_lock(tmp_path):
    first = RunLock(tmp_path).acquire()
    try:
        (tmp_path / LOCK_NAME).unlink()
        with pytest.raises(SomiteError) as caught:
            RunLock(tmp_path).acquire()
        assert "in use by another process" in str(caught.value)
        assert not (tmp_path / LOCK_NAME).exists()  # the refused opener created nothing
    finally:
        first.release()
    with RunLock(tmp_path) as second:
        assert json.loads(second.path.read_text())["pid"] == os.getpid()
    assert not (tmp_path / LOCK_NAME).exists()


def test_deleting_the_lock_file_does_not_let_another_process_in(tmp_path):
    code = ("import sys\nfrom somite.experiments.lock import RunLock\n"
            "RunLock(sys.argv[1]).acquire()\n")
    with RunLock(tmp_path):
        (tmp_path / LOCK_NAME).unlink()
        other = subprocess.run([sys.executable, "-c", code, str(tmp_path)],
                               capture_output=True, text=True)
        assert other.returncode != 0 and "in use by" in other.stderr


def test_release_leaves_a_later_owners_lock_file_alone(tmp_path):
    # Without a folder lock (a file system that cannot flock a folder), someone deleting our
    # file lets another owner create its own: our release must not delete that one.
    with RunLock(tmp_path) as lock:
        (tmp_path / LOCK_NAME).unlink()
        (tmp_path / LOCK_NAME).write_text("someone else's\n")
        assert lock.held
    assert (tmp_path / LOCK_NAME).read_text() == "someone else's\n"


def test_without_a_folder_lock_the_file_lock_alone_still_works(tmp_path, monkeypatch):
    real_flock = lock_module.fcntl.flock

    def flock(fd, operation):
        if os.path.isdir(f"/proc/self/fd/{fd}"):
            raise OSError(95, "Operation not supported")
        return real_flock(fd, operation)

    monkeypatch.setattr(lock_module.fcntl, "flock", flock)
    with RunLock(tmp_path) as lock:
        assert lock._folder_fd is None
        with pytest.raises(SomiteError, match=f"in use by process {os.getpid()} "):
            RunLock(tmp_path).acquire()
    assert not (tmp_path / LOCK_NAME).exists()


# 3. A failed write releases everything.

def test_a_failed_write_releases_the_lock(tmp_path, monkeypatch):
    def pwrite(*args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(lock_module.os, "pwrite", pwrite)
    lock = RunLock(tmp_path)
    with pytest.raises(SomiteError) as caught:
        lock.acquire()
    assert str(caught.value) == (f"out={str(tmp_path)!r}: cannot write its {LOCK_NAME} "
                                 "(No space left on device)")
    assert not lock.held
    monkeypatch.undo()
    with RunLock(tmp_path) as again:  # the same process tries again: not "in use"
        assert json.loads(again.path.read_text())["pid"] == os.getpid()
    lock.acquire()  # the very object that failed, too
    lock.release()


def test_a_failed_truncate_releases_the_lock(tmp_path, monkeypatch):
    def ftruncate(*args):
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(lock_module.os, "ftruncate", ftruncate)
    with pytest.raises(SomiteError, match=r"cannot write its \.somite\.lock \(Input/output"):
        RunLock(tmp_path).acquire()
    monkeypatch.undo()
    with RunLock(tmp_path):
        pass


# 4. Commands that write into a run directory take its lock.

def test_is_run_folder(tmp_path, run):
    assert is_run_folder(run, RUN_MARKERS)
    assert not is_run_folder(tmp_path / "nowhere", RUN_MARKERS)
    plain = tmp_path / "plain"
    plain.mkdir()
    assert not is_run_folder(plain, RUN_MARKERS)
    (plain / LOCK_NAME).write_text("")
    assert is_run_folder(plain, RUN_MARKERS)
    with lock_if_run(tmp_path / "nowhere", RUN_MARKERS) as held:
        assert held is None


@pytest.fixture
def locked(tmp_path):
    """A folder whose lock a RunLock holds (as a running run's would be)."""
    folder = tmp_path / "busy"
    folder.mkdir()
    with RunLock(folder):
        yield folder


def test_discover_into_a_locked_folder_is_refused(run, locked, capsys):
    before = contents(locked)
    refused(capsys, ["discover", str(run), "--out", str(locked)], "out=", "in use by process")
    assert contents(locked) == before


def test_draw_into_a_locked_folder_is_refused(run, locked, capsys):
    before = contents(locked)
    refused(capsys, ["draw", str(run), "--out", str(locked / "brain.png")], "in use by process")
    assert contents(locked) == before


def test_module_export_into_a_locked_folder_is_refused(run, locked, capsys):
    before = contents(locked)
    refused(capsys, ["module", "export", str(run), "--module", "front", "--out",
                     str(locked / "front.json")], "in use by process")
    assert contents(locked) == before


def test_commands_into_a_running_run_are_refused_even_with_its_lock_file_deleted(run, capsys):
    before = contents(run)
    with RunLock(run):
        (run / LOCK_NAME).unlink()
        refused(capsys, ["discover", str(run), "--out", str(run)], "in use by")
        refused(capsys, ["draw", str(run), "--out", str(run / "brain.svg")], "in use by")
        refused(capsys, ["module", "export", str(run), "--module", "front", "--out",
                         str(run / "front.json")], "in use by")
    assert contents(run) == before


def test_module_export_onto_a_run_file_is_refused(run, capsys):
    before = contents(run)
    for name in ("best.json", "config.json", "checkpoint.json", MANIFEST):
        err = refused(capsys, ["module", "export", str(run), "--module", "front", "--out",
                               str(run / name)], f"out={str(run / name)!r}", name)
        assert "run directory" in err
    assert contents(run) == before


def test_commands_into_an_idle_run_write_and_leave_no_lock(run, tmp_path, capsys):
    assert main(["discover", str(run), "--out", str(run)]) == 0
    assert main(["draw", str(run), "--out", str(run / "brain.svg")]) == 0
    assert main(["module", "export", str(run), "--module", "front", "--out",
                 str(run / "front.json")]) == 0
    for name in ("partition.json", "candidates.csv", "brain.svg", "front.json"):
        assert (run / name).is_file(), name
    assert not (run / LOCK_NAME).exists()
    # A folder that is not a run's gets no lock file at any moment.
    plain = tmp_path / "plain"
    plain.mkdir()
    seen = []
    real = lock_module.RunLock.acquire

    def acquire(self):
        seen.append(self.folder)
        return real(self)

    lock_module.RunLock.acquire = acquire
    try:
        assert main(["discover", str(run), "--out", str(plain)]) == 0
        assert main(["draw", str(run), "--out", str(plain / "brain.svg")]) == 0
        assert main(["module", "export", str(run), "--module", "front", "--out",
                     str(plain / "front.json")]) == 0
    finally:
        lock_module.RunLock.acquire = real
    assert seen == [] and not (plain / LOCK_NAME).exists()
    capsys.readouterr()
