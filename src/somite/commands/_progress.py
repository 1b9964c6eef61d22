"""What a command shows while a user waits: the one-time compile, generations, frames, stages.

Every wait longer than a moment shows, on a terminal or not, unless the command was given
``--quiet``: on a terminal a live line on standard error (what is being done, a bar when the
total is known, the seconds elapsed, ticking); off a terminal (a log file, ``| tee``) the same
text as a plain line every :data:`HEARTBEAT_SECONDS`, so that a log shows the job alive and
where it is. Results go to standard output; all of this goes to standard error.
"""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager, nullcontext

COMPILE_SECONDS = 60
"""About how long the first episode takes to compile the simulation kernels on a cold Numba
cache, on the 2-core machine of BENCHMARKS.md (later runs load them from disk at once): about
45 s in a fresh clone's first `make demo` on 2 idle cores, 53 s as the CPU seconds of the two
processes that share it say (2026-12-07, "The first compile on two cores"); longer when other
work shares the cores."""

HEARTBEAT_SECONDS = 15.0
"""Off a terminal, how often a wait says where it is."""

COMPILING = (f"compiling the simulation kernels (once, about {COMPILE_SECONDS} s on 2 cores, "
             "longer under load; later runs start at once)")


class Waiting:
    """A wait shown as the module docstring says; ``update`` says where it is.

    ``text`` describes the wait; ``total`` (optional) is the count of ``unit`` s it waits for
    (generations, frames), shown as a bar and ``done/total``; ``eta`` adds the time remaining.
    ``transient`` erases the live line at the end (else it stays, as a record of the run).
    """

    def __init__(self, text: str, total: int | None = None, unit: str = "",
                 quiet: bool = False, eta: bool = False, transient: bool = True) -> None:
        self.text, self.total, self.unit, self.done = text, total, unit, 0
        self.quiet, self.eta, self.transient = quiet, eta, transient
        self.started = time.monotonic()
        self.bar = None
        self._stop = threading.Event()
        self._thread = None
        self._stream = None

    # -- what a command calls ----------------------------------------------------------------

    def update(self, text: str | None = None, done: int | None = None,
               total: int | None = None) -> None:
        if text is not None:
            self.text = text
        if done is not None:
            self.done = done
        if total is not None:
            self.total = total
        if self.bar is not None:
            self.bar.update(self.task, description=self.text, completed=self.done,
                            total=self.total)

    def say(self, line: str) -> None:
        """Print ``line`` on standard error (above the live line on a terminal)."""
        if self.bar is not None:
            self.bar.console.print(line, highlight=False, soft_wrap=True, markup=False)
        else:
            sys.stderr.write(line + "\n")
            sys.stderr.flush()

    def line(self) -> str:
        """Where the wait is, as one plain line (the heartbeat off a terminal)."""
        count = f"{self.done}/{self.total} {self.unit}: " if self.total is not None else ""
        return f"{count}{self.text} ({time.monotonic() - self.started:.0f} s elapsed)"

    # -- showing it ----------------------------------------------------------------------------

    def __enter__(self) -> Waiting:
        if self.quiet:
            return self
        self.started = time.monotonic()
        if sys.stderr.isatty():
            self._start_bar()
        else:
            self._stream = sys.stderr
            self._thread = threading.Thread(target=self._beat, daemon=True)
            self._thread.start()
        return self

    def _start_bar(self) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            SpinnerColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        columns = [SpinnerColumn()]
        if self.total is not None:
            columns += [BarColumn(), MofNCompleteColumn(), TextColumn(f"{self.unit}:")]
        columns.append(TextColumn("{task.description}"))
        columns.append(TimeElapsedColumn())
        if self.eta:
            columns.append(TimeRemainingColumn())
        self.bar = Progress(*columns, console=Console(stderr=True), transient=self.transient)
        self.bar.start()
        self.task = self.bar.add_task(self.text, total=self.total, completed=self.done)

    def _beat(self) -> None:
        while not self._stop.wait(HEARTBEAT_SECONDS):
            try:
                self._stream.write(self.line() + "\n")
                self._stream.flush()
            except (OSError, ValueError):  # stderr closed: nothing to tell anyone
                return

    def __exit__(self, kind, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self.bar is not None:
            if kind is not None:
                # Erase the bar, so that an error is the only line left on the terminal.
                self.bar.live.transient = True
            self.bar.stop()


def will_compile(backend: str = "cpu") -> bool:
    """Whether the next episode waits for the simulation kernels to compile (a cold cache)."""
    if backend != "cpu":
        return False
    from .._jit import on_disk
    from ..tasks.lanes import run_group

    return on_disk(run_group) is False


def simulating(text: str, quiet: bool = False, backend: str = "cpu"):
    """A :class:`Waiting` around the episodes of a command without a progress bar of its own
    (``text``: what they are); when the kernels are not compiled yet it says so at once, and
    the live line says that it is compiling them."""
    if quiet:
        return nullcontext()
    if will_compile(backend):
        sys.stderr.write(COMPILING + "...\n")
        sys.stderr.flush()
        text = f"{text} (compiling the kernels first)"
    return Waiting(text)


@contextmanager
def rendering(what: str, quiet: bool = False):
    """Progress of drawing frames; yields the ``progress(done, total)`` callback of
    :func:`somite.viz.video.write_episode` (None when quiet)."""
    if quiet:
        yield None
        return
    # The frames' count comes with the first frame.
    with Waiting(what, total=0, unit="frames") as wait:

        def progress(done: int, total: int) -> None:
            wait.update(done=done, total=total)

        yield progress


@contextmanager
def stages(quiet: bool = False):
    """A live line naming the stage of a long job; yields ``stage(text)`` (a no-op when quiet)."""
    if quiet:
        yield lambda text: None
        return
    with Waiting("starting") as wait:
        yield lambda text: wait.update(text=text)
