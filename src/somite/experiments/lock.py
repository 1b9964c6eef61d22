"""One process per run directory: a lock file held for the run's life.

The lock is ``fcntl.flock`` on ``LOCK_NAME`` inside the directory, not a file created with
``O_CREAT | O_EXCL``. The kernel drops a flock when its process dies, however it dies
(SIGKILL included), so a lock left behind by a dead process is free to take at once: no
"is this pid still alive?" guess, which a reused pid or a process on another host sharing the
folder would fool, and no window between finding a lock stale and taking it over in which two
processes could both take it. The file's content (pid, host, start time) only names the
holder in the refusal; a file whose holder died is simply rewritten by the next owner.

The file is removed on release while still locked; an opener that locked a file already
unlinked notices (its descriptor's inode is no longer the path's) and tries again.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import time
from pathlib import Path

from ..errors import bad

LOCK_NAME = ".somite.lock"


def _holder(path: Path) -> str:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return (f"process {int(data['pid'])} on {data['host']} "
                f"(started {data['started']})")
    except (OSError, ValueError, KeyError, TypeError):
        return "another process (it has not written its name yet)"


class RunLock:
    """An exclusive lock on the run directory ``folder`` (which must exist).

    Use as a context manager, or :meth:`acquire` and :meth:`release`. A second
    :class:`RunLock` on the same folder, in this process or another, is refused with a
    one-line :class:`~somite.errors.SomiteError` naming the holder.
    """

    def __init__(self, folder: str | os.PathLike) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> RunLock:
        while self._fd is None:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            except OSError as error:
                raise bad("out", str(self.folder), f"cannot lock it ({error.strerror})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise bad("out", str(self.folder),
                          f"in use by {_holder(self.path)}; wait for it to finish or stop it"
                          ) from None
            except OSError as error:
                os.close(fd)
                raise bad("out", str(self.folder), f"cannot lock it ({error.strerror})") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if not same:  # released and unlinked by its holder between our open and flock
                os.close(fd)
                continue
            started = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
            text = json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                               "started": started}) + "\n"
            os.ftruncate(fd, 0)
            os.pwrite(fd, text.encode(), 0)
            self._fd = fd
        return self

    def release(self) -> None:
        if self._fd is None:
            return
        # Unlink before unlocking: whoever opens the path afterwards gets a fresh file.
        self.path.unlink(missing_ok=True)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
