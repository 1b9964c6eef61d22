"""What a command shows while a user waits: the one-time compile, rendering a video."""

from __future__ import annotations

import sys
from contextlib import contextmanager

COMPILE_SECONDS = 240
"""About how long the first episode takes to compile the simulation kernels on a cold Numba
cache, on the 2-core machine of BENCHMARKS.md (later runs load them from disk at once): 200 s
before the vector lanes of issue 25, which compile 22% longer."""


def note_compiling(quiet: bool = False, backend: str = "cpu") -> None:
    """Say, before the first episode, that it waits for a compile (only when it will, and
    only to a terminal: a log or a test reading stderr gets results and errors, not this)."""
    if quiet or backend != "cpu" or not sys.stderr.isatty():
        return
    from .._jit import on_disk
    from ..tasks.lanes import run_group

    if on_disk(run_group) is False:
        sys.stderr.write(f"compiling the simulation kernels (once, about {COMPILE_SECONDS} s "
                         "on 2 cores; later runs start at once)...\n")
        sys.stderr.flush()


@contextmanager
def rendering(what: str, quiet: bool = False):
    """A progress bar for drawing frames; yields the ``progress(done, total)`` callback of
    :func:`somite.viz.video.write_episode` (None when quiet)."""
    if quiet:
        yield None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    with Progress(TextColumn(what), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                  transient=True) as bar:
        task = bar.add_task(what, total=None)

        def progress(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield progress


@contextmanager
def stages(quiet: bool = False):
    """A spinner naming the stage of a long job; yields ``stage(text)`` (a no-op when quiet)."""
    if quiet:
        yield lambda text: None
        return
    from rich.console import Console

    with Console(stderr=True).status("starting") as status:
        yield lambda text: status.update(text)
