"""One process per run directory: a lock held for the run's life.

The lock is ``fcntl.flock``, not a file created with ``O_CREAT | O_EXCL``. The kernel drops a
flock when its process dies, however it dies (SIGKILL included), so a lock left behind by a
dead process is free to take at once: no "is this pid still alive?" guess, which a reused pid
or a process on another host sharing the folder would fool, and no window between finding a
lock stale and taking it over in which two processes could both take it.

Two flocks are taken, in this order (issue 23):

1. on the run directory itself (a descriptor opened with ``O_DIRECTORY``). Deleting
   ``LOCK_NAME`` during a run does not free this one: the directory's inode outlives the
   file, and a folder holding a run cannot be removed while it holds files. Some network file
   systems cannot flock a directory (``EBADF``, ``ENOLCK``, ``EOPNOTSUPP``, ``EINVAL``), and
   a folder we may write in but not read cannot be opened for it (``EACCES``): there the file
   lock below is the lock alone, as before issue 23, and deleting the file by hand during a
   run does let a second process in.
2. on ``LOCK_NAME`` inside it, opened with ``O_NOFOLLOW`` and refused unless it is a regular
   file with no other hard link: somite never writes through a link into a file outside the
   run. The file also keeps older somite versions (which take only this lock) out, and its
   content (pid, host, start time) names the holder in the refusal; a file whose holder died
   is simply rewritten by the next owner.

The file is removed on release while still locked; an opener that locked a file already
unlinked notices (its descriptor's inode is no longer the path's) and tries again. If
anything fails once a flock is taken (a full disk refuses the holder's name), everything is
released before the one-line error: a long-lived process (a campaign worker) can try again.

:func:`lock_if_run` is for commands that write into a folder that may be a run directory
(``discover``, ``draw``, ``module export``): they take the run's lock while they write.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import stat
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import SomiteError, bad

LOCK_NAME = ".somite.lock"

_NO_FOLDER_LOCK = frozenset({errno.EBADF, errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP,
                             errno.EINVAL})
"""Errors of flocking a directory that mean "this file system cannot", not "it is held"."""

_HOLDER_BYTES = 4096
"""The most of a lock file :func:`_holder` reads: a holder's name is under 200 bytes."""


def read_holder(path: Path) -> dict | None:
    """The holder a lock file names (``pid``, ``host``, ``started``), or None; read without
    following a link and without blocking (a FIFO put in its place), at most
    :data:`_HOLDER_BYTES`."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        data = json.loads(os.read(fd, _HOLDER_BYTES).decode("utf-8"))
        return {"pid": int(data["pid"]), "host": str(data["host"]),
                "started": str(data.get("started", "at an unknown time"))}
    except (OSError, ValueError, KeyError, TypeError, RecursionError):
        return None
    finally:
        os.close(fd)


def _holder(path: Path) -> str:
    """Who holds the lock, in words, for a refusal."""
    data = read_holder(path)
    if data is None:
        return "another process (it has not written its name yet)"
    return f"process {data['pid']} on {data['host']} (started {data['started']})"


def _unlock(fd: int | None) -> None:
    """Unlock and close ``fd`` (explicitly unlocked: a forked child sharing the descriptor
    must not keep the lock alive); never raises."""
    if fd is None:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_UN)
    except OSError:
        pass
    try:
        os.close(fd)
    except OSError:
        pass


class RunLock:
    """An exclusive lock on the run directory ``folder`` (which must exist).

    Use as a context manager, or :meth:`acquire` and :meth:`release`. A second
    :class:`RunLock` on the same folder, in this process or another, is refused with a
    one-line :class:`~somite.errors.SomiteError` naming the holder.
    """

    def __init__(self, folder: str | os.PathLike, field: str = "out") -> None:
        self.folder = Path(folder)
        self.field = field  # what a refusal names: a run's --out, a packed campaign
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None
        self._folder_fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def _error(self, why: str) -> SomiteError:
        return bad(self.field, str(self.folder), why)

    def _in_use(self) -> SomiteError:
        return self._error(f"in use by {_holder(self.path)}; wait for it to finish or stop it")

    def _not_regular(self) -> SomiteError:
        return self._error(f"its {LOCK_NAME} is a symbolic link (or not a regular file); "
                           "remove it")

    def acquire(self) -> RunLock:
        if self._fd is not None:
            return self
        folder_fd = self._lock_folder()
        fd = None
        try:
            fd = self._lock_file()
            self._write_holder(fd)
        except BaseException as error:
            if fd is not None:
                self._unlink_own(fd)
            _unlock(fd)
            _unlock(folder_fd)
            if isinstance(error, OSError):
                raise self._error(f"cannot write its {LOCK_NAME} "
                                  f"({error.strerror or error})") from None
            raise
        self._fd, self._folder_fd = fd, folder_fd
        return self

    def _lock_folder(self) -> int | None:
        """The directory's descriptor, flocked; None where the file system cannot flock it."""
        try:
            fd = os.open(self.folder, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        except OSError as error:
            if error.errno == errno.EACCES:  # writable but not readable: the file lock alone
                return None
            raise self._error(f"cannot lock it ({error.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise self._in_use() from None
        except OSError as error:
            os.close(fd)
            if error.errno in _NO_FOLDER_LOCK:
                return None
            raise self._error(f"cannot lock it ({error.strerror})") from None
        return fd

    def _lock_file(self) -> int:
        """The lock file's descriptor, flocked, still the one at :attr:`path`."""
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC
                             | os.O_NONBLOCK, 0o666)
            except OSError as error:
                if error.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO):
                    raise self._not_regular() from None
                raise self._error(f"cannot lock it ({error.strerror})") from None
            try:
                info = os.fstat(fd)
                if not stat.S_ISREG(info.st_mode):
                    raise self._not_regular()
                if info.st_nlink > 1:  # truncating it would truncate a file elsewhere too
                    raise self._error(f"its {LOCK_NAME} is a hard link to another file "
                                      f"({info.st_nlink} links); remove it")
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise self._in_use() from None
            except OSError as error:
                os.close(fd)
                raise self._error(f"cannot lock it ({error.strerror})") from None
            except BaseException:
                os.close(fd)
                raise
            try:
                same = self._is_path_of(fd)
            except OSError as error:
                _unlock(fd)
                raise self._error(f"cannot lock it ({error.strerror})") from None
            if same:
                return fd
            # Released and unlinked by its holder between our open and flock.
            _unlock(fd)

    def _is_path_of(self, fd: int) -> bool:
        """Whether :attr:`path` (not followed) is the file open as ``fd``."""
        try:
            mine, there = os.fstat(fd), os.stat(self.path, follow_symlinks=False)
        except FileNotFoundError:
            return False
        return (mine.st_dev, mine.st_ino) == (there.st_dev, there.st_ino)

    def _write_holder(self, fd: int) -> None:
        started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
        data = (json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                            "started": started}) + "\n").encode()
        os.ftruncate(fd, 0)
        if os.pwrite(fd, data, 0) != len(data):
            raise OSError(errno.ENOSPC, "a short write")

    def _unlink_own(self, fd: int) -> None:
        """Remove :attr:`path` if it is still our file (not one a later owner created after
        someone deleted ours); never raises."""
        try:
            if self._is_path_of(fd):
                self.path.unlink()
        except OSError:
            pass

    def release(self) -> None:
        if self._fd is None:
            return
        fd, folder_fd = self._fd, self._folder_fd
        self._fd = self._folder_fd = None
        # Unlink before unlocking: whoever opens the path afterwards gets a fresh file.
        self._unlink_own(fd)
        _unlock(fd)
        _unlock(folder_fd)

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def is_run_folder(folder: str | os.PathLike, run_files: Iterable[str]) -> bool:
    """Whether ``folder`` is a run directory: an existing folder holding :data:`LOCK_NAME` or
    any of ``run_files`` (links and all: what matters is that a run may own the folder)."""
    folder = Path(folder)
    return folder.is_dir() and any(os.path.lexists(folder / name)
                                   for name in (LOCK_NAME, *run_files))


@contextmanager
def lock_if_run(folder: str | os.PathLike, run_files: Iterable[str]) -> Iterator[RunLock | None]:
    """Hold ``folder``'s :class:`RunLock` for the ``with`` block when it is a run directory
    (:func:`is_run_folder`), so that a command writing into a running run's folder is refused
    with the usual "in use by ..." line; do nothing (yield None) for any other folder, which
    is then left without a lock file.

    ``run_files`` are the names that make a folder a run's: pass
    :data:`somite.experiments.runner.RUN_FILES` (and its ``MANIFEST``). They are a parameter
    because :mod:`.runner` imports this module, not the reverse."""
    if not is_run_folder(folder, run_files):
        yield None
        return
    with RunLock(folder) as lock:
        yield lock
