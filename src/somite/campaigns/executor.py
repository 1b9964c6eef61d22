"""Running a campaign's tasks on Dask distributed: a LocalCluster, or an existing scheduler.

Every unfinished task is one Dask task (:func:`~.work.run_task`), handed to Dask when a
worker thread is free for it and the tasks it needs have finished, in the campaign's order
(:func:`priorities`); a cluster that grows or shrinks gets more or fewer at once. A task
whose worker dies is rescheduled by Dask, and one that fails is retried (``retries``): either
way it runs again and resumes from what is on disk. Tasks carry the campaign directory's
absolute path, so workers on other machines need the same path to it (a shared file system).

Sizing: a task is single-process Numba code whose Python between kernel calls (3% of a
generation) leaves threads idle, so by default each core gets a worker process of its own with
one Numba thread (``workers = cores // threads``); campaigns have far more runs than cores until
their last few tasks.
"""

from __future__ import annotations

import importlib.util
import logging
import os
import re
import signal
import threading
import time
import uuid
import warnings
from collections.abc import Callable
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import bad
from .directory import finished
from .kinds import estimate
from .work import run_task

RETRIES = 3
CONNECT_TIMEOUT = "30s"
"""How long :func:`connect` tries to reach a ``--scheduler``."""


@dataclass
class Execution:
    """What a call of :func:`execute` did."""

    ran: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    started: list[str] = field(default_factory=list)
    wall_s: float = 0.0
    dashboard: str = ""


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def check_scheduler(address: str | None) -> None:
    """A scheduler address such as ``tcp://HOST:PORT``, or a one-line error."""
    if address is not None and not re.fullmatch(r"([a-z]+://)?[^\s:/]+:\d+", address):
        raise bad("scheduler", address, "expected an address such as tcp://HOST:8786")


def sizing(workers: int | None, threads: int | None) -> tuple[int, int]:
    """(worker processes, Numba threads per task) for a LocalCluster on this machine."""
    n = cores()
    for name, value in (("workers", workers), ("threads", threads)):
        if value is not None and value < 1:
            raise bad(name, value, "must be at least 1")
    if threads is None:
        threads = max(1, n // workers) if workers else 1
    if workers is None:
        workers = max(1, n // threads)
    return workers, threads


class Connection:
    """A Dask client: of the scheduler at ``scheduler``, or (None) of a LocalCluster of
    ``workers`` processes started here; a context manager that closes both. ``campaign run``
    connects before it writes anything, so that a scheduler it cannot reach leaves nothing
    behind (and a rerun is not refused as a campaign already there)."""

    def __init__(self, scheduler: str | None, workers: int) -> None:
        self.client, self.cluster = _client(scheduler, workers)

    def close(self, interrupted: bool = False) -> None:
        """Close the client and the cluster; ``interrupted``: a Ctrl-C is unwinding, and what
        Dask logs while its nannies stop (a worker killed mid-task, a close timed out on a
        loaded machine) is not shown: the user stopped it, and gets one line."""
        with _dask_quiet() if interrupted else nullcontext():
            self.client.close()
            if self.cluster is not None:
                self.cluster.close()

    def __enter__(self) -> Connection:
        return self

    def __exit__(self, kind, *exc) -> None:
        self.close(interrupted=kind is not None and issubclass(kind, KeyboardInterrupt))


@contextmanager
def _dask_quiet():
    """This process's logging off (a LocalCluster's nannies log from here, each under its own
    logger and level), then back as it was."""
    before = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(before)


def connect(scheduler: str | None, workers: int | None = None,
            threads: int | None = None) -> Connection:
    """:class:`Connection` to ``scheduler`` (sized by :func:`sizing` for a LocalCluster), or
    a one-line error."""
    check_scheduler(scheduler)
    return Connection(scheduler, sizing(workers, threads)[0])


def _client(scheduler: str | None, workers: int):
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout=CONNECT_TIMEOUT), None
        except (OSError, TimeoutError, ValueError) as error:
            reason = (str(error).strip().splitlines() or [type(error).__name__])[0]
            raise bad("scheduler", scheduler, f"cannot connect ({reason})") from None
    # Without bokeh the scheduler serves no dashboard, only its health pages: then it takes
    # any free port, and two campaigns on one machine never meet on Dask's 8787 (the second
    # would retry another port, leaking a socket).
    address = ":8787" if _has_bokeh() else ":0"
    with warnings.catch_warnings(), _deaf_to_ctrl_c():
        # "Port 8787 is already in use" (another cluster's dashboard): this one takes another
        # port, and the progress view shows which.
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               silence_logs=logging.ERROR, dashboard_address=address)
    client = Client(cluster)
    client.register_plugin(_quiet_plugin())
    return client, cluster


class _Open(logging.Filter):
    """Passes a record while its worker is not shutting down."""

    def __init__(self, worker) -> None:
        super().__init__()
        self.worker = worker

    def filter(self, record: logging.LogRecord) -> bool:
        from distributed.core import Status

        return self.worker.status not in (Status.closing, Status.closing_gracefully,
                                          Status.closed, Status.failed)


def _quiet_plugin():
    """A worker plugin that applies :func:`_quiet_while_closing` to every worker of the local
    cluster, those its nannies start again later (a worker killed, or out of memory) too: a
    one-off ``client.run`` reached only the first ones."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class QuietWhileClosing(WorkerPlugin):
        name = "somite-quiet-while-closing"

        def setup(self, worker) -> None:
            _quiet_while_closing(worker)

    return QuietWhileClosing()


def _quiet_while_closing(dask_worker) -> None:
    """On a local worker (it writes to this terminal): nothing it logs once it is closing is
    shown. Stopped by Ctrl-C on a loaded machine, a worker logged the reset of its nanny's
    connection with three tracebacks before the campaign's one line."""
    for handler in logging.getLogger("distributed").handlers + logging.getLogger().handlers:
        handler.addFilter(_Open(dask_worker))


@contextmanager
def _deaf_to_ctrl_c():
    """Ctrl-C reaches every process of the terminal's group: the local workers, stopped by it
    mid-task, printed four tracebacks before this process's one line. They start with SIGINT
    blocked (a spawned process inherits the mask and Python keeps it), and this process gets
    a Ctrl-C pressed meanwhile once they have started; closing the cluster stops them."""
    main = threading.current_thread() is threading.main_thread()
    if not main or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _has_bokeh() -> bool:
    return importlib.util.find_spec("bokeh") is not None


def dashboard_link(client, local: bool) -> str:
    """The address of Dask's dashboard, or "" (a local one needs bokeh: without it the
    scheduler serves no status pages)."""
    if local and not _has_bokeh():
        return ""
    try:
        info = client.scheduler_info()
        if "dashboard" not in info.get("services", {}):
            return ""
        return client.dashboard_link
    except Exception:  # noqa: BLE001 - a missing dashboard must not stop a campaign
        return ""


def execute(directory: str | Path, doc: dict, scheduler: str | None = None,
            workers: int | None = None, threads: int | None = None, retries: int = RETRIES,
            watch: Callable[[Execution], None] | None = None,
            connection: Connection | None = None) -> Execution:
    """Run every unfinished task of the campaign ``doc`` in ``directory``; ``watch`` is called
    about twice a second while it goes on (for a progress view). With ``connection`` (of
    :func:`connect`) the tasks run there, and it is left open; else one is made and closed."""
    directory = Path(directory).resolve()
    tasks = [t for t in doc["tasks"] if not finished(directory, t)]
    outcome = Execution()
    if not tasks:
        return outcome
    workers, threads = sizing(workers, threads)
    start = time.perf_counter()
    own = connection is None
    if own:
        connection = Connection(scheduler, workers)
    client, cluster = connection.client, connection.cluster
    from distributed import wait

    running: dict[str, object] = {}
    interrupted = False
    try:
        outcome.dashboard = dashboard_link(client, cluster is not None)
        token = uuid.uuid4().hex[:8]  # a scheduler may hold another campaign's tasks
        waiting = submission_order(tasks, priorities(directory, tasks))
        while waiting or running:
            for task_id, future in list(running.items()):
                if future.done():
                    del running[task_id]
                    if future.status == "finished":
                        outcome.ran.append(task_id)
                    else:
                        outcome.failed[task_id] = _reason(future)
            for task in startable(waiting, outcome, slots(client) - len(running)):
                waiting.remove(task)
                outcome.started.append(task["id"])
                running[task["id"]] = client.submit(
                    run_task, str(directory), task, threads, key=f"{task['id']}@{token}",
                    pure=False, retries=retries)
            for task in skippable(waiting, outcome):
                waiting.remove(task)
                outcome.skipped.append(task["id"])
            outcome.wall_s = time.perf_counter() - start
            if watch is not None:
                watch(outcome)
            if running:  # back as soon as one finishes, to hand its thread the next task
                try:
                    wait(list(running.values()), timeout=0.5, return_when="FIRST_COMPLETED")
                except TimeoutError:
                    pass
            elif waiting:
                time.sleep(0.5)
    except KeyboardInterrupt:
        interrupted = True
        with _dask_quiet():
            client.cancel(list(running.values()))
        raise
    except BaseException:
        client.cancel(list(running.values()))
        raise
    finally:
        if own:
            connection.close(interrupted)
    outcome.wall_s = time.perf_counter() - start
    return outcome


def slots(client) -> int:
    """How many tasks the cluster runs at once now: its workers' threads (a task is one
    thread of Dask's; its Numba threads are its own), at least 1, so that a cluster whose
    workers have not joined yet holds the next task for the first of them."""
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001 - a scheduler that does not answer now: one at a time
        return 1


def startable(waiting: list[dict], outcome: Execution, free: int) -> list[dict]:
    """The tasks to hand to Dask now: the first ``free`` of ``waiting`` (in the order to
    start them) whose needs have all run, a need outside the campaign's unfinished tasks
    counting as run. Dask itself would give each worker a queue of its own at submission and
    start a later task on a worker that frees up before an earlier one queued on a busy
    worker, so the campaign hands out a task only when a thread is free for it."""
    if free <= 0:
        return []
    ran = set(outcome.ran)
    pending = {t["id"] for t in waiting} | set(outcome.started) - ran
    chosen = []
    for task in waiting:
        if all(n in ran or n not in pending for n in task["needs"]):
            chosen.append(task)
            if len(chosen) == free:
                break
    return chosen


def skippable(waiting: list[dict], outcome: Execution) -> list[dict]:
    """The tasks that will never run: a task they need failed, or was skipped (in order, so
    that a chain of needs is skipped at once)."""
    lost = set(outcome.failed) | set(outcome.skipped)
    skipped = []
    for task in waiting:
        if any(n in lost for n in task["needs"]):
            lost.add(task["id"])
            skipped.append(task)
    return skipped


def priorities(directory: Path, tasks: list[dict]) -> dict[str, int]:
    """Each unfinished task's rank in the order the campaign starts them (higher first):
    the tasks already begun (their folder exists), in the campaign's order, then
    the others seed by seed (:func:`replicates`), each seed in the campaign's order. So a
    campaign of several seeds completes every experiment's seed 0, then every experiment's
    seed 1, ...: stopped part-way (machine time runs out), it holds the same number of finished
    seeds of every experiment, which a comparison between experiments needs, and few partial
    runs. Begun ones first: a campaign grown by seeds finishes the runs it has first. A task
    that simulates nothing (a discovery: its estimate is 0 robot-control-steps) and whose needs
    have all run comes before every task not begun that does: it takes a worker for seconds,
    rather than waiting hours behind runs for a result that costs nothing (one whose run is
    still to come keeps its place among its seed's tasks)."""
    seeds = replicates(tasks)
    place = {task["id"]: rank for rank, task in enumerate(tasks)}

    def key(task: dict) -> tuple:
        begun = (directory / task["path"]).is_dir()
        ready = all(need not in place for need in task["needs"])
        costly = not begun and (estimate(task) > 0 or not ready)
        return (not begun, costly, 0 if begun or not costly else seeds[task["id"]],
                place[task["id"]])

    ranked = sorted(tasks, key=key)
    return {task["id"]: len(tasks) - rank for rank, task in enumerate(ranked)}


def replicates(tasks: list[dict]) -> dict[str, int]:
    """Each task's replicate, the seed it belongs to when seeds are run one after another: an
    evolution run's own seed; a task built on other tasks (a reassembly on its donors, a
    discovery on its run) the highest replicate among them, as it can start only once they are
    done; any other task its ``seed`` option, else 0. Needs outside ``tasks`` (finished ones)
    count as 0."""
    by_id = {task["id"]: task for task in tasks}
    seeds: dict[str, int] = {}

    def seed(task_id: str) -> int:
        if task_id not in by_id:
            return 0
        if task_id not in seeds:
            task = by_id[task_id]
            if task["kind"] == "evolve" or not task["needs"]:
                seeds[task_id] = int(task["options"].get("seed", 0))
            else:
                seeds[task_id] = max(seed(n) for n in task["needs"])
        return seeds[task_id]

    return {task["id"]: seed(task["id"]) for task in tasks}


def submission_order(tasks: list[dict], priority: dict[str, int]) -> list[dict]:
    """``tasks`` by ``priority``, highest first, each after the tasks it needs (their futures
    must exist when it is submitted)."""
    waiting = sorted(tasks, key=lambda task: -priority[task["id"]])
    ids = {task["id"] for task in tasks}
    done: set[str] = set()
    order = []
    while waiting:
        task = next(t for t in waiting if all(n in done or n not in ids for n in t["needs"]))
        waiting.remove(task)
        done.add(task["id"])
        order.append(task)
    return order


def _reason(future) -> str:
    try:
        error = future.exception()
    except Exception as failure:  # noqa: BLE001 - cancelled, lost: say so
        error = failure
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0] if text else ''}"
