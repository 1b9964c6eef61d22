"""Every write failure is one line (issue 23): a full disk, a read-only or immutable target, a
name too long for the system, a run that ``--force`` cannot delete. Each ends in one
``error: out=...`` line with the OS's reason and exit code 2, leaves no temporary file and
leaves the old file as it was.

A full disk is simulated by making the low-level write fail with ENOSPC (``os.write`` under
:func:`somite._io.write_atomic`; matplotlib's and PIL's save under the viz writers), and, where
the machine lets root mount a 64 KiB tmpfs, also met for real. Read-only targets are made
read-only for real (``chmod`` as a user; ``chattr +i`` as root, who ignores file modes) and,
as that depends on the machine, also by making ``os.access`` say so.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from somite.cli import main

NO_SPACE = os.strerror(errno.ENOSPC)  # "No space left on device"
ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
EVOLVE = ["evolve", "--shape", "worm", "--population", "4", "--generations", "1",
          "--duration", "1", "--quiet"]
CAMPAIGN = {"format": "somite-campaign", "version": 1, "name": "x", "source": "test",
            "experiments": {"a": {}}, "tasks": []}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A run of one generation of four worms, 1 s each (a second to make)."""
    run = tmp_path_factory.mktemp("run") / "R"
    assert main([*EVOLVE, "--out", str(run)]) == 0
    return run


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """A campaign folder without tasks: its report is written in a second."""
    folder = tmp_path_factory.mktemp("campaign")
    (folder / "campaign.json").write_text(json.dumps(CAMPAIGN))
    return folder


def contents(folder: Path) -> dict[str, bytes]:
    """Every file of ``folder`` (recursively) and its bytes: temporary files included."""
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_error(capsys, *parts: str) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "error: out=" in err, err
    for part in parts:
        assert part in err, err
    return err


def write_then_fail(monkeypatch, owner, name: str) -> None:
    """Make ``owner.name(self, target, ...)`` write ``target``, cut it short and raise ENOSPC,
    as a disk that fills up during the write does."""
    original = getattr(owner, name)

    def save(self, target, *args, **kwargs):
        original(self, target, *args, **kwargs)
        with open(target, "r+b") as handle:
            handle.truncate(os.path.getsize(target) // 2)
        raise OSError(errno.ENOSPC, NO_SPACE)

    monkeypatch.setattr(owner, name, save)


def full_os_write(monkeypatch) -> None:
    """``os.write`` to a file (not stdout or stderr) writes a few bytes, then fails: ENOSPC."""
    original = os.write

    def write(fd, data):
        if fd <= 2:
            return original(fd, data)
        if len(data) > 8:
            return original(fd, bytes(data[:8]))
        raise OSError(errno.ENOSPC, NO_SPACE)

    monkeypatch.setattr(os, "write", write)


# -- a full disk --------------------------------------------------------------------------------


def test_draw_on_a_full_disk(run_dir, tmp_path, capsys, monkeypatch):
    import matplotlib.figure

    out = tmp_path / "brain.png"
    out.write_bytes(b"the old drawing")
    before = contents(tmp_path)
    write_then_fail(monkeypatch, matplotlib.figure.Figure, "savefig")
    assert main(["draw", str(run_dir), "--out", str(out)]) == 2
    one_error(capsys, "brain.png", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_plot_on_a_full_disk_keeps_the_old_figure_and_statistics(run_dir, tmp_path, capsys,
                                                                 monkeypatch):
    import matplotlib.figure

    out = tmp_path / "fig.png"
    out.write_bytes(b"the old figure")
    (tmp_path / "fig.stats.json").write_text("the old statistics")
    before = contents(tmp_path)
    write_then_fail(monkeypatch, matplotlib.figure.Figure, "savefig")
    assert main(["plot", str(run_dir), "--out", str(out)]) == 2
    one_error(capsys, "fig.png", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_plot_whose_statistics_meet_a_full_disk_renames_neither(run_dir, tmp_path, capsys,
                                                                monkeypatch):
    out = tmp_path / "fig.svg"
    out.write_bytes(b"the old figure")
    (tmp_path / "fig.stats.json").write_text("the old statistics")
    before = contents(tmp_path)
    write_text = Path.write_text

    def half_then_full(self, data, *args, **kwargs):
        if ".stats." not in self.name:
            return write_text(self, data, *args, **kwargs)
        write_text(self, data[: len(data) // 2], *args, **kwargs)
        raise OSError(errno.ENOSPC, NO_SPACE)

    monkeypatch.setattr(Path, "write_text", half_then_full)
    assert main(["plot", str(run_dir), "--out", str(out)]) == 2
    one_error(capsys, "fig.stats.json", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_show_strip_on_a_full_disk(run_dir, tmp_path, capsys, monkeypatch):
    import PIL.Image

    out = tmp_path / "strip.png"
    out.write_bytes(b"the old strip")
    before = contents(tmp_path)
    write_then_fail(monkeypatch, PIL.Image.Image, "save")
    assert main(["show", str(run_dir), "--duration", "1", "--frames", "2",
                 "--out", str(out)]) == 2
    one_error(capsys, "strip.png", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_show_video_whose_encoder_fails_is_one_line(run_dir, tmp_path, capsys, monkeypatch):
    """imageio-ffmpeg's error holds ffmpeg's command and output on many lines: the first is
    the reason."""
    import somite.viz.video

    def broken_pipe(images, path, fps):
        Path(path).write_bytes(b"half a video")
        raise OSError("[Errno 32] Broken pipe\n\nFFMPEG COMMAND:\nffmpeg -y -f rawvideo\n\n"
                      "FFMPEG STDERR OUTPUT:\n")

    out = tmp_path / "walk.mp4"
    out.write_bytes(b"the old video")
    before = contents(tmp_path)
    monkeypatch.setattr(somite.viz.video, "_write_mp4", broken_pipe)
    assert main(["show", str(run_dir), "--duration", "1", "--out", str(out)]) == 2
    one_error(capsys, "walk.mp4", "cannot write it ([Errno 32] Broken pipe)")
    assert contents(tmp_path) == before


@pytest.fixture
def full_ffmpeg(tmp_path_factory, monkeypatch):
    """An ffmpeg that writes half a video, says the disk is full and exits 1, as the real one
    does on a full disk (imageio's writer took that for success: a truncated video, exit 0)."""
    import imageio_ffmpeg

    fake = tmp_path_factory.mktemp("bin") / "ffmpeg"
    fake.write_text('#!/bin/sh\nfor last; do :; done\nhead -c 1000 > /dev/null\n'
                    'printf "half a video" > "$last"\n'
                    'echo "[out#0/mp4] Error writing trailer: No space left on device" >&2\n'
                    'echo "Conversion failed!" >&2\nexit 1\n')
    fake.chmod(0o755)
    monkeypatch.setattr(imageio_ffmpeg, "get_ffmpeg_exe", lambda: str(fake))


def test_show_video_on_a_full_disk(run_dir, tmp_path, capsys, full_ffmpeg):
    out = tmp_path / "walk.mp4"
    out.write_bytes(b"the old video")
    before = contents(tmp_path)
    assert main(["show", str(run_dir), "--duration", "1", "--width", "64", "--height", "48",
                 "--out", str(out)]) == 2
    one_error(capsys, "walk.mp4", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_show_gif_on_a_full_disk(run_dir, tmp_path, capsys, monkeypatch):
    import PIL.Image

    write_then_fail(monkeypatch, PIL.Image.Image, "save")
    assert main(["show", str(run_dir), "--duration", "1", "--width", "64", "--height", "48",
                 "--out", str(tmp_path / "walk.gif")]) == 2
    one_error(capsys, "walk.gif", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == {}


def test_report_on_a_full_disk(campaign, tmp_path, capsys, monkeypatch):
    out = tmp_path / "report"
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    before = contents(tmp_path)
    assert "report/report.json" in before
    capsys.readouterr()
    full_os_write(monkeypatch)
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 2
    one_error(capsys, "report.json", f"cannot write it ({NO_SPACE})")
    assert contents(tmp_path) == before


def test_a_rename_that_fails_is_one_line(campaign, tmp_path, capsys, monkeypatch):
    out = tmp_path / "report"
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    before = contents(tmp_path)
    capsys.readouterr()

    def refuse(source, target):
        raise OSError(errno.EPERM, os.strerror(errno.EPERM))

    monkeypatch.setattr(os, "replace", refuse)
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 2
    one_error(capsys, "report.json", f"cannot write it ({os.strerror(errno.EPERM)})")
    assert contents(tmp_path) == before


@pytest.fixture
def old_report(campaign, tmp_path, capsys) -> Path:
    """A report folder holding a complete report, a figure of an older one and a file of the
    user's."""
    out = tmp_path / "report"
    assert main(["report", str(campaign), "--out", str(out), "--quiet"]) == 0
    (out / "figures" / "old.png").write_bytes(b"a figure of an older report")
    (out / "notes.txt").write_text("the user's")
    capsys.readouterr()
    return out


def test_a_report_failing_midway_keeps_the_old_one_whole(campaign, old_report, tmp_path,
                                                         capsys, monkeypatch):
    """report.json is written, index.md meets a full disk: neither replaces the old report."""
    import somite.report.build

    before = contents(tmp_path)
    real = somite.report.build.write_atomic

    def full_at_index(path, text, field="out"):
        if Path(path).name == "index.md":
            full_os_write(monkeypatch)
        return real(path, text, field)

    monkeypatch.setattr(somite.report.build, "write_atomic", full_at_index)
    assert main(["report", str(campaign), "--out", str(old_report), "--quiet"]) == 2
    err = one_error(capsys, str(old_report), f"cannot write it ({NO_SPACE})")
    assert ".new" not in err  # the report's file or folder, not the hidden one's
    assert contents(tmp_path) == before


def test_a_report_that_cannot_create_a_folder_is_one_line(campaign, old_report, tmp_path,
                                                          capsys, monkeypatch):
    before = contents(tmp_path)
    mkdir = Path.mkdir

    def refuse_figures(self, *args, **kwargs):
        if self.name == "figures":
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))
        return mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", refuse_figures)
    assert main(["report", str(campaign), "--out", str(old_report), "--quiet"]) == 2
    one_error(capsys, f"{old_report}/figures", f"cannot write it ({os.strerror(errno.EACCES)})")
    assert contents(tmp_path) == before
    fresh = tmp_path / "fresh"
    assert main(["report", str(campaign), "--out", str(fresh), "--quiet"]) == 2
    one_error(capsys, os.strerror(errno.EACCES))
    assert not fresh.exists()  # nothing left behind


def test_a_report_whose_swap_fails_puts_the_old_one_back(campaign, old_report, tmp_path,
                                                         capsys, monkeypatch):
    before = contents(tmp_path)
    rename = os.rename

    def refuse_the_new_index(source, target):
        if Path(source).name == "index.md" and Path(source).parent.name.endswith(".new"):
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return rename(source, target)

    monkeypatch.setattr(os, "rename", refuse_the_new_index)
    assert main(["report", str(campaign), "--out", str(old_report), "--quiet"]) == 2
    one_error(capsys, os.strerror(errno.EIO))
    assert contents(tmp_path) == before


def test_a_new_report_replaces_the_old_one_whole(campaign, old_report, capsys):
    (old_report / "cache").mkdir()
    (old_report / "cache" / "validation.json").write_text("a cache")
    assert main(["report", str(campaign), "--out", str(old_report), "--quiet"]) == 0
    assert sorted(p.name for p in old_report.iterdir()) == sorted(
        ["cache", "figures", "index.md", "notes.txt", "report.json"]
        + (["index.html"] if (old_report / "index.html").exists() else []))
    assert list((old_report / "figures").iterdir()) == []  # the older report's figure is gone
    assert (old_report / "notes.txt").read_text() == "the user's"
    assert (old_report / "cache" / "validation.json").read_text() == "a cache"  # kept


@pytest.fixture
def small_disk(tmp_path):
    """A 64 KiB tmpfs (root only, where mounting is allowed), unmounted after the test."""
    if not ROOT or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    disk = tmp_path / "disk"
    disk.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(disk)],
                          capture_output=True)
    if done.returncode != 0:
        pytest.skip("this machine does not let root mount a tmpfs")
    try:
        yield disk
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def fill(disk: Path) -> None:
    """Write zeros into ``disk`` until it is full."""
    handle = os.open(disk / "filler", os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        while True:
            os.write(handle, b"\0" * 4096)
    except OSError as error:
        assert error.errno == errno.ENOSPC
    finally:
        os.close(handle)


def test_a_real_full_disk(run_dir, campaign, small_disk, capsys):
    old = small_disk / "brain.png"
    old.write_bytes(b"the old drawing")
    (small_disk / "report").mkdir()
    (small_disk / "report" / "report.json").write_text("the old report")
    fill(small_disk)
    before = contents(small_disk)
    assert main(["draw", str(run_dir), "--out", str(old)]) == 2
    one_error(capsys, "brain.png", f"cannot write it ({NO_SPACE})")
    assert main(["report", str(campaign), "--out", str(small_disk / "report"), "--quiet"]) == 2
    one_error(capsys, "report", NO_SPACE)
    assert contents(small_disk) == before


def test_a_real_full_disk_under_a_video(run_dir, small_disk, capsys):
    """The real ffmpeg on a full 64 KiB tmpfs."""
    fill(small_disk)
    before = contents(small_disk)
    assert main(["show", str(run_dir), "--duration", "1", "--width", "64", "--height", "48",
                 "--out", str(small_disk / "walk.mp4")]) == 2
    one_error(capsys, "walk.mp4", f"cannot write it ({NO_SPACE})")
    assert contents(small_disk) == before


# -- a read-only target -------------------------------------------------------------------------


@pytest.fixture(params=["real", "access"])
def make_read_only(request, monkeypatch):
    """``make_read_only(path)``: for real (``chmod 0o444``; as root, who ignores modes,
    ``chattr +i``, skipped where the file system has no such flag), or by ``os.access``
    saying so (the same check, on any machine)."""
    undo = []

    def make(path: Path) -> None:
        if request.param == "access":
            access = os.access
            monkeypatch.setattr(os, "access", lambda p, mode: (
                not (Path(p) == path and mode & os.W_OK) and access(p, mode)))
        elif not ROOT:
            path.chmod(0o444)
            undo.append(lambda: path.chmod(0o644))
        else:
            if shutil.which("chattr") is None or subprocess.run(
                    ["chattr", "+i", str(path)], capture_output=True).returncode != 0:
                pytest.skip("root ignores a file's mode, and chattr +i is not available here")
            undo.append(lambda: subprocess.run(["chattr", "-i", str(path)]))

    yield make
    for step in undo:
        step()


@pytest.mark.parametrize("command", [
    ["draw", "{run}", "--out", "{out}/brain.png"],
    ["plot", "{run}", "--out", "{out}/fig.png"],
    ["plot", "{run}", "--out", "{out}/fig.png", "stats"],  # fig.stats.json read-only
    ["show", "{run}", "--duration", "1", "--frames", "2", "--out", "{out}/strip.png"],
], ids=["draw", "plot", "plot-stats", "show"])
def test_a_read_only_target_is_refused_before_any_work(command, run_dir, tmp_path, capsys,
                                                       make_read_only):
    args = [a.format(run=run_dir, out=tmp_path) for a in command]
    target = Path(args[args.index("--out") + 1])
    if args[-1] == "stats":
        args.pop()
        target = target.with_name("fig.stats.json")
    target.write_bytes(b"keep me")
    before = contents(tmp_path)
    make_read_only(target)
    assert main(args) == 2
    one_error(capsys, target.name, "exists and is read-only; it is not replaced")
    assert contents(tmp_path) == before


# -- a name too long ----------------------------------------------------------------------------


LONG = "a" * 300


@pytest.mark.parametrize("command, why", [
    (["draw", "{run}", "--out", "{out}/" + LONG + ".png"], "its name is too long"),
    (["draw", "{run}", "--out", "{out}/" + "a" * 240 + ".png"], "temporary file"),
    (["plot", "{run}", "--out", "{out}/" + LONG + ".png"], "its name is too long"),
    (["plot", "{run}", "--out", "{out}/" + "a" * 228 + ".png"], "too long"),  # .stats.json
    (["show", "{run}", "--frames", "2", "--out", "{out}/" + LONG + ".png"], "too long"),
    (["show", "{run}", "--out", "{out}/" + "/".join(["b" * 200] * 25) + "/w.mp4"],
     "the path is too long"),
    ([*EVOLVE, "--out", "{out}/" + LONG], "a name in it is too long"),
    (["report", "{campaign}", "--out", "{out}/" + LONG + "/r"], "a name in it is too long"),
])
def test_a_name_too_long_is_refused_before_any_work(command, why, run_dir, campaign, tmp_path,
                                                    capsys):
    args = [a.format(run=run_dir, out=tmp_path, campaign=campaign) for a in command]
    assert main(args) == 2
    one_error(capsys, why)
    assert list(tmp_path.iterdir()) == []


# -- evolve --force -----------------------------------------------------------------------------


@pytest.fixture
def old_run(run_dir, tmp_path) -> Path:
    run = tmp_path / "run"
    shutil.copytree(run_dir, run)
    return run


def test_force_over_a_read_only_best_deletes_nothing(old_run, capsys, make_read_only):
    before = contents(old_run)
    make_read_only(old_run / "best.json")
    assert main([*EVOLVE, "--out", str(old_run), "--force"]) == 2
    one_error(capsys, "its best.json is read-only", "nothing was deleted")
    assert contents(old_run) == before
    capsys.readouterr()


def test_force_that_cannot_delete_a_file_puts_the_others_back(old_run, capsys, monkeypatch):
    """A refusal that os.access does not foresee (an append-only file, a sticky folder):
    the files moved aside before it go back."""
    before = contents(old_run)
    rename = os.rename

    def refuse_log(source, target):
        if Path(source).name == "log.csv":
            raise OSError(errno.EPERM, os.strerror(errno.EPERM))
        return rename(source, target)

    monkeypatch.setattr(os, "rename", refuse_log)
    assert main([*EVOLVE, "--out", str(old_run), "--force"]) == 2
    one_error(capsys, f"cannot delete its log.csv ({os.strerror(errno.EPERM)})",
              "nothing was deleted")
    assert contents(old_run) == before


def test_force_still_replaces_a_writable_run(old_run, capsys):
    assert main([*EVOLVE, "--out", str(old_run), "--force", "--seed", "1"]) == 0
    assert json.loads((old_run / "config.json").read_text())["seed"] == 1
    assert sorted(p.name for p in old_run.iterdir()) == sorted(
        ["best.json", "bests.jsonl", "checkpoint.json", "config.json", "log.csv",
         "manifest.json", "physics.json"])


# -- plot: a run whose final best is NaN --------------------------------------------------------


def test_plot_names_the_runs_it_leaves_out(run_dir, tmp_path, capsys):
    kept, lost = tmp_path / "kept", tmp_path / "lost"
    shutil.copytree(run_dir, kept)
    shutil.copytree(run_dir, lost)
    log = lost / "log.csv"
    header, *rows = log.read_text().splitlines()
    column = header.split(",").index("best_velocity")
    last = rows[-1].split(",")
    last[column] = "nan"
    log.write_text("\n".join([header, *rows[:-1], ",".join(last)]) + "\n")
    out = tmp_path / "fig.png"
    assert main(["plot", str(kept), str(lost), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    warning = [line for line in err.splitlines() if "left out" in line]
    assert warning == [f"somite plot: warning: 1 of 2 runs left out: their final best v_x is "
                       f"NaN or infinite, so they are in no box, median or test: {lost}"]
    stats = json.loads((tmp_path / "fig.stats.json").read_text())
    assert stats["left_out"] == [str(lost)]
    group = stats["groups"]["shape=worm"]
    assert group["n"] == 1 and group["runs"] == [str(kept), str(lost)]


def test_plot_without_a_nan_leaves_nothing_out(run_dir, tmp_path, capsys):
    assert main(["plot", str(run_dir), "--out", str(tmp_path / "fig.png")]) == 0
    assert "left out" not in capsys.readouterr().err
    assert json.loads((tmp_path / "fig.stats.json").read_text())["left_out"] == []
