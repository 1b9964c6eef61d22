"""somite._threads.spread hands every task out exactly once, the calling thread taking part."""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numba
import pytest

from somite._threads import spread


def _record(done: list, fail_at: int | None = None):
    def task(i: int) -> None:
        time.sleep(0.001)  # long enough for the other threads to take tasks too
        done.append((i, threading.get_ident()))
        if i == fail_at:
            raise ValueError(f"task {i}")
    return task


@pytest.mark.parametrize("n_tasks", [0, 1, 2, 7, 40])
@pytest.mark.parametrize("with_pool", [False, True])
def test_every_task_runs_once(n_tasks, with_pool):
    done: list = []
    if with_pool:
        with ThreadPoolExecutor(3) as pool:
            spread(_record(done), n_tasks, pool)
    else:
        spread(_record(done), n_tasks)
    assert sorted(i for i, _ in done) == list(range(n_tasks))


def test_the_calling_thread_takes_a_share():
    done: list = []
    with ThreadPoolExecutor(1) as pool:
        spread(_record(done), 40, pool)
    threads = {thread for _, thread in done}
    if numba.get_num_threads() > 1:
        assert threading.get_ident() in threads and len(threads) == 2
    else:
        assert threads == {threading.get_ident()}


def test_a_failing_task_is_raised_after_the_others_ran():
    done: list = []
    with ThreadPoolExecutor(2) as pool, pytest.raises(ValueError, match="task 5"):
        spread(_record(done, fail_at=5), 20, pool)
    # The thread that failed stops; the others take what is left (alone, the caller stops).
    expected = range(20) if numba.get_num_threads() > 1 else range(6)
    assert sorted(i for i, _ in done) == list(expected)
