"""A report written all or nothing: built beside the old one, swapped in when complete.

A report is many files (report.json, index.md, figures, caches). Replacing them one by one
would leave a mix of the old and the new report when a write fails halfway (a full disk), so
:func:`staged_report` builds the new report in a hidden folder inside the report folder (the
same file system, where a rename cannot fail for want of space) and only when it is complete
moves the old report's entries aside and the new ones in; a failure there puts the old ones
back. The caches and the time-lapse strips they name are hard-linked into the new report
first, so that a second report stays quick; a write there replaces the link, never the old
file.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path

from .._io import make_folder, reason
from ..errors import SomiteError, bad

ENTRIES = ("report.json", "index.md", "index.html", "figures", "cache")
"""What a report folder holds of the report's; anything else in it is the user's, left alone."""

STAGING = re.compile(r"\.report\.(?P<pid>\d+)\.[0-9a-f]{8}\.(new|old)")
"""The hidden folders of a report being built (``.new``) or replaced (``.old``)."""


@contextlib.contextmanager
def staged_report(out: Path, strips: str = "timelapse.json") -> Iterator[Path]:
    """Yield an empty folder to build the report in, seeded with ``out``'s caches; when the
    block succeeds, make it ``out``'s report. On any failure ``out`` is left as it was (a
    folder created for it removed again) and an OSError is a one-line error naming the path
    (the report's, not the hidden folder's)."""
    created = not out.exists()
    make_folder(out)
    tag = f".report.{os.getpid()}.{uuid.uuid4().hex[:8]}"
    new, old = out / f"{tag}.new", out / f"{tag}.old"
    try:
        try:
            _check_entries(out)
            _remove_abandoned(out)
            new.mkdir()
            _seed(out, new, strips)
            yield new
            _swap(out, new, old)
        except OSError as error:
            where = Path(error.filename) if error.filename else out
            raise bad("out", _shown(where, new, out), f"cannot write it ({reason(error)})"
                      ) from None
        except SomiteError as error:
            raise _as_the_reports(error, new, out) from None
    except BaseException:
        _remove(new)
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty: nothing of the user's is deleted
        raise
    finally:
        _remove(new)
        _remove(old)


def _as_the_reports(error: SomiteError, new: Path, out: Path) -> SomiteError:
    """``error`` naming the report folder where it named the hidden one: the file's path in
    ``out`` where the message holds it whole, else ``out`` itself (a long path is shortened
    in the message, with the hidden folder's name in the part left out)."""
    text = str(error)
    if f"{new}{os.sep}" in text:
        return SomiteError(text.replace(f"{new}{os.sep}", f"{out}{os.sep}"))
    match = _SHORTENED.fullmatch(text)
    if match and repr(str(new)).startswith(match["head"]):
        tail = match["tail"].rstrip("'")
        rest = tail.partition(f".new{os.sep}")[2]
        shown = str(out / rest) if rest else f"{out}{os.sep}...{tail}"
        return bad(match["field"], shown, match["why"])
    return error


_SHORTENED = re.compile(r"(?P<field>[\w.\[\]-]+)=(?P<head>.+?)\.\.\.(?P<tail>.*?) "
                        r"\(\d+ characters\): (?P<why>.*)", re.S)
"""A message of :func:`somite.errors.bad` whose value was shortened: ``field=head...tail (N
characters): why``."""


def _check_entries(out: Path) -> None:
    """Refuse, before any work, a report folder whose report.json, index.md or index.html
    is a folder (or figures/ or cache/ a file): not an older report's, and the swap would
    delete it."""
    for name in ENTRIES:
        path = out / name
        if path.is_symlink() or not path.exists():
            continue
        folder = name in ("figures", "cache")
        if path.is_dir() != folder:
            kind = "a file" if folder else "a folder"
            raise bad("out", str(out), f"its {name} is {kind}, not a report's (a new report "
                      "would replace it); move it away")


def _shown(path: Path, new: Path, out: Path) -> str:
    """``path`` as the user knows it: in the report folder, not the hidden one."""
    try:
        return str(out / path.relative_to(new))
    except ValueError:
        return str(path)


def _seed(out: Path, new: Path, strips: str) -> None:
    """Hard-link (or copy) the old report's caches into ``new``, and the strips its
    time-lapse cache names into ``new/figures``: what the report would otherwise redo."""
    from .rerun import read_cache

    cache = out / "cache"
    if cache.is_dir() and not cache.is_symlink():
        (new / "cache").mkdir()
        for path in cache.iterdir():
            if path.is_file() and not path.is_symlink():
                _link(path, new / "cache" / path.name)
    figures = out / "figures"
    if figures.is_dir() and not figures.is_symlink():
        (new / "figures").mkdir()
        for name in read_cache(new / "cache" / strips):
            path = figures / str(name)
            if path.parent == figures and path.is_file() and not path.is_symlink():
                _link(path, new / "figures" / path.name)


def _link(source: Path, target: Path) -> None:
    try:
        os.link(source, target)
    except OSError:  # a file system without hard links
        shutil.copy2(source, target)


def _swap(out: Path, new: Path, old: Path) -> None:
    """Move the old report's entries into ``old`` and ``new``'s into ``out``; if a rename
    fails (or the process is interrupted), undo the ones done and raise its error."""
    old.mkdir()
    moved, placed = [], []
    try:
        for name in ENTRIES:
            if os.path.lexists(out / name):
                os.rename(out / name, old / name)
                moved.append(name)
        for name in ENTRIES:
            if os.path.lexists(new / name):
                os.rename(new / name, out / name)
                placed.append(name)
    except BaseException:
        for name in reversed(placed):
            with contextlib.suppress(OSError):
                os.rename(out / name, new / name)
        for name in reversed(moved):
            with contextlib.suppress(OSError):
                os.rename(old / name, out / name)
        raise


def _remove(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)


def _remove_abandoned(out: Path) -> None:
    """Delete the hidden folders of reports killed while building here (their process is
    gone): only they could still write there."""
    for path in out.iterdir():
        match = STAGING.fullmatch(path.name)
        if match and path.is_dir() and not path.is_symlink() and not _alive(int(match["pid"])):
            _remove(path)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return not _zombie(pid)


def _zombie(pid: int) -> bool:
    """Whether ``pid`` has ended but not yet been reaped by its parent (a report killed a
    moment ago, whose parent has not waited for it): it writes nothing any more. Linux's
    /proc says so; elsewhere, False."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    # "pid (name) S ...": the state follows the name's closing parenthesis.
    return stat[stat.rfind(")") + 2:][:1] in ("Z", "X")


__all__ = ["ENTRIES", "staged_report"]
