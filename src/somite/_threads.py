"""Spreading compiled work over the cores from Python.

Kernels are compiled without ``parallel=True``: a ``prange`` loop has Numba optimise and emit
the whole call tree below it again for its gufunc, and its index is unsigned, so every
robot-level function called from it was compiled a second time for the stepper's signed index
(the first compile with and without ``prange``: BENCHMARKS.md, "First compile and the test
suite"). Every kernel releases the GIL (``nogil``), so plain threads calling them run in
parallel instead. The number of threads is Numba's (``numba.set_num_threads``,
``NUMBA_NUM_THREADS``), as it was for the ``prange`` loops.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Executor, ThreadPoolExecutor, wait

import numba

THREAD_NAME = "somite-spread"
"""The name prefix of the helper threads :func:`spread` starts (the command line looks for
them when it is interrupted: see :func:`somite.cli.main`)."""


def threads_for(n_tasks: int) -> int:
    """The threads that ``n_tasks`` tasks get: Numba's thread count, at most one a task."""
    return max(1, min(numba.get_num_threads(), n_tasks))


def spread(task: Callable[[int], None], n_tasks: int, pool: Executor | None = None) -> None:
    """``task(i)`` for every i in ``range(n_tasks)``, handed out one at a time to the calling
    thread and to the workers of ``pool`` if given (else to :func:`threads_for` - 1 workers
    started for this call); the first exception of a task is raised here once all have
    ended. The calling thread takes its share: handing every task to the pool and waiting
    cost a worker's wake-up more each call (the stepper calls this once a control step)."""
    helpers = threads_for(n_tasks) - 1
    if pool is None and helpers == 0:
        for i in range(n_tasks):
            task(i)
        return
    if pool is None:
        own = ThreadPoolExecutor(helpers, thread_name_prefix=THREAD_NAME)
        interrupted = True
        try:
            spread(task, n_tasks, own)
            interrupted = False
        finally:
            own.shutdown(wait=not interrupted, cancel_futures=True)
        return
    # next() on a range iterator is one step under the GIL, so no task is taken twice.
    todo = iter(range(n_tasks))
    stop = []

    def drain() -> None:
        for i in todo:
            if stop:
                return
            task(i)

    futures = [pool.submit(drain) for _ in range(min(helpers, n_tasks - 1))]
    try:
        drain()
    except (KeyboardInterrupt, SystemExit):
        # Ctrl-C or SIGTERM (raised in this, the main, thread): stop handing out tasks and
        # do not wait for those under way, which cannot be interrupted: a kernel's first
        # compile takes minutes, and a command must stop within a second or two. Their
        # results are never read; the command line then ends the process (cli.main).
        stop.append(True)
        for future in futures:
            future.cancel()
        raise
    except BaseException:
        wait(futures)
        raise
    wait(futures)
    for future in futures:
        future.result()
