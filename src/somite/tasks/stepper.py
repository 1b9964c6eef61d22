"""An episode stepped from Python, one control step at a time (brax's ``reset``/``step``).

:class:`Episode` runs the batch's robots as the compiled loop does: started by
:func:`~somite.tasks.episode.start`, then each control step over the batch's groups of robots
of one body (:func:`~somite.tasks.lanes.step_group`: the loop's own step, their joints as
vector lanes), over state it keeps between calls (a :class:`~somite.tasks.work.Work` of
batch arrays and the groups' lanes), so an episode stepped to its end leaves the trace that
:func:`~somite.tasks.lanes.run_batch` leaves, bit for bit. Each call runs one compiled
function a thread, over that thread's share of the groups. :func:`step_batch` steps each robot
alone through :func:`~somite.tasks.episode.control_step` (the one-robot physics; the tests'
reference).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from concurrent.futures import Executor, ThreadPoolExecutor

import numpy as np

from .. import checks
from .._jit import njit
from .._threads import THREAD_NAME, spread, threads_for
from ..brain.compile import compile_genome
from ..brain.genome import Genome
from ..budget import check_batch
from ..errors import SomiteTypeError, bad, bad_type
from ..limits import MAX_STEPPED
from ..sim.body import Body
from ..sim.config import SimConfig, pack_params
from ..sim.sensors import lidar_rays, noise_table
from ..sim.terrain import Terrain
from . import arguments
from .episode import (
    STATUS_OK,
    Batch,
    Trace,
    control_step,
    finish,
    new_trace,
    robot_state,
    start,
    work_row,
)
from .lanes import NOT_TIMED, groups, new_groups, step_groups
from .work import new_work
from .locomotion import compile_batch


@njit
def _start_robots(batch, first, stride):
    system, trace = batch.system, batch.trace
    for b in range(first, system.n_points.shape[0], stride):
        state = robot_state(system, b, batch.params,
                            work_row(batch.work, b, system, batch.ctrl, batch.params),
                            batch.rays)
        start(b, system, batch.params, trace, state)
        finish(b, trace, state)


@njit
def _step_robots(k, batch, given, first, stride):
    system, trace = batch.system, batch.trace
    recording = trace.pos.shape[0] > 0
    for b in range(first, system.n_points.shape[0], stride):
        if trace.status[b] == STATUS_OK:
            state = robot_state(system, b, batch.params,
                                work_row(batch.work, b, system, batch.ctrl, batch.params),
                                batch.rays)
            if given.shape[0] > 0:
                # What was in force over step k is what the trace shows at step k - 1, which
                # decided it.
                actuation = state.work.brain.actuation
                for v in range(actuation.shape[0]):
                    actuation[v] = given[b, v]
                    if recording:
                        trace.actuation[b, k - 1, v] = given[b, v]
            control_step(k, b, batch, state)
            finish(b, trace, state)


KERNELS = (_start_robots, new_groups, step_groups)
"""The compiled functions that :class:`Episode` runs (to ask whether Numba's cache holds them:
:func:`somite._jit.on_disk`)."""


def _by_threads(kernel, args, n_robots: int, pool: Executor | None, threads: int | None):
    # Thread j takes robots j, j + T, j + 2T, ...: neighbours in a batch (a shape's robots,
    # a population's) cost alike, so each thread gets a like share.
    threads = threads or threads_for(n_robots)
    spread(lambda j: kernel(*args, j, threads), threads, pool)


def start_batch(batch: Batch, pool: Executor | None = None, threads: int | None = None) -> None:
    """:func:`~somite.tasks.episode.start` every robot of ``batch`` over its row of
    ``batch.work``, the robots spread over ``threads`` threads (default: Numba's thread count),
    those of ``pool`` if given, else started for this call."""
    _by_threads(_start_robots, (batch,), batch.system.n_points.shape[0], pool, threads)


def step_batch(k, batch: Batch, given, pool: Executor | None = None,
               threads: int | None = None) -> None:
    """Control step ``k`` of every robot of ``batch`` still running; ``given`` (B, V) replaces
    the actuation in force over the step (0 rows: the controllers' own). Threads as in
    :func:`start_batch`."""
    _by_threads(_step_robots, (k, batch, given), batch.system.n_points.shape[0], pool, threads)


def step_in_groups(k, batch: Batch, groups, given, pool: Executor | None = None,
                   threads: int | None = None) -> None:
    """:func:`step_batch` over the batch's groups of robots (``groups``:
    :func:`~somite.tasks.lanes.new_groups` of the started batch), as the compiled loop advances
    them: the same numbers, a group's robots as vector lanes. Thread j takes groups j, j + T,
    ... of the T threads."""
    threads = threads or threads_for(batch.system.n_points.shape[0])
    spread(lambda j: step_groups(k, batch, given, groups, j, threads), threads, pool)


def real_array(field: str, value) -> np.ndarray:
    """``value`` as a float64 array, if it holds real numbers (not strings, bools, complex or
    objects, which NumPy would convert silently or refuse deep inside); a one-line error naming
    ``field`` otherwise."""
    if isinstance(value, (str, bytes)):
        raise bad_type(field, value, "an array of numbers")
    try:
        array = np.asarray(value)
    except (ValueError, TypeError):  # a ragged list
        raise bad_type(field, value, "an array of numbers") from None
    if array.dtype.kind not in "iuf":
        raise SomiteTypeError(str(bad(field, value, f"expected real numbers (float or int), "
                                      f"not values of dtype {array.dtype}")))
    return array.astype(np.float64, copy=False)


def _read_only(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


class Episode:
    """A batch of episodes stepped from Python: robot b = (``robots[b]``, ``terrains[b]``).

    ``robots`` are :class:`~somite.brain.genome.Genome` s (each carries its body) or
    controllers (``Zero()``, ``Sine(...)``, compiled graphs) with ``bodies``; ``terrains`` is one
    terrain for all (a name or a :class:`~somite.sim.terrain.Terrain`) or one per robot;
    ``seeds`` seeds the sensor noise as in :func:`~somite.tasks.locomotion.simulate_batch`.
    With ``record`` the trace keeps every step's positions, actuation, readings and contacts.

    ``step()`` advances every robot one control step with its own controller; ``step(a)``
    with ``a`` (B, V) in [-1, 1] (V: the batch's most voxels; a robot reads its first
    ``n_voxels`` columns) puts ``a`` in force over that step instead of the actuation that its
    controller decided at the step before (a robot's controller still runs; its output is
    replaced at the next ``step(a)``). So ``a`` may be computed from :attr:`readings`, as the
    controllers compute theirs. A robot whose state went non-finite stops
    (``trace.status``).

    Step numbers (the same in every entry point: docs/architecture.md, "Step 0"): the i-th
    call (i = 0, 1, ...) is the physics over [i, i + 1] / 60 s, under actuation i, the row
    ``trace.actuation[:, i]``. Actuation 0 is always 0, the robots at rest: no controller has
    read anything before it, and ``a`` given to the first call is checked but not put in force.
    So a sequence ``A`` given call by call moves a robot as ``Table(A)`` does in the compiled
    loop, bit for bit.
    """

    def __init__(
        self,
        robots: Sequence,
        terrains: Sequence[Terrain | str] | Terrain | str,
        config: SimConfig | None = None,
        seeds: Sequence[int] | int = 0,
        record: bool = False,
        bodies: Sequence[Body] | None = None,
    ):
        config = arguments.sim_config("config", config)
        robots = checks.items("robots", robots, MAX_STEPPED)
        n = len(robots)
        if n == 0:
            raise bad("robots", [], "an episode needs one robot at least")
        record = checks.flag("record", record)
        for i, robot in enumerate(robots):
            arguments.robot(f"robots[{i}]", robot)
        if bodies is None:
            for i, robot in enumerate(robots):
                if not isinstance(robot, Genome):
                    raise bad("bodies", None, f"robots[{i}] is a controller: controllers "
                              "need bodies=; a Genome carries its own")
            bodies = [robot.body for robot in robots]
        else:
            bodies = checks.items("bodies", bodies, MAX_STEPPED)
            if len(bodies) != n:
                raise bad("bodies", f"{len(bodies)} bodies", f"need one per robot ({n})")
            for i, (robot, body) in enumerate(zip(robots, bodies)):
                arguments.body(f"bodies[{i}]", body)
                if isinstance(robot, Genome) and robot.body != body:
                    raise bad(f"bodies[{i}]", body.shape.grid_string(),
                              f"robots[{i}] is a genome of body {robot.body.shape.grid_string()}")
        seeds = checks.seeds("seeds", seeds, n)
        worlds = arguments.terrains("terrains", terrains, n, MAX_STEPPED)
        check_batch(n, max(b.shape.n_voxels for b in bodies))
        controllers = [compile_genome(r) if isinstance(r, Genome) else r for r in robots]
        self.config = config
        self.system, self.controllers, seeds = compile_batch(bodies, worlds, controllers,
                                                             config, seeds)
        self._params = pack_params(config)
        self._noise = noise_table(config)
        self._seeds = np.asarray(seeds, dtype=np.uint64)
        self._rays = lidar_rays(self._params)
        self._trace = new_trace(n, config.n_steps, self.system, record)
        # Zeros: the padding beyond a robot's own counts shows in the views, as in the trace.
        self._work = new_work(self.system, self.controllers, self._params, np.zeros)
        self._no_actuation = np.zeros((0, self.n_voxels))
        self._k = 0
        # Held while a step runs: a second thread stepping at once would interleave the
        # two steps' work on one state (another trajectory, silently); it is refused.
        self._stepping = threading.Lock()
        # One pool for the episode's life (starting threads at every step would cost more
        # than a small batch's step); the calling thread is the last of the threads.
        self._threads = threads_for(n)
        self._pool = (ThreadPoolExecutor(self._threads - 1, thread_name_prefix=THREAD_NAME)
                      if self._threads > 1 else None)
        self._batch = Batch(self.system, self.controllers, self._params, self._noise,
                            self._seeds, config.n_steps, self._trace, self._work, self._rays)
        start_batch(self._batch, self._pool, self._threads)
        # Robots of one body advance together, as in the compiled loop (tasks/lanes.py); the
        # groups keep their lanes' state between steps.
        self._groups = new_groups(self._batch, *groups(self.system, threads=self._threads),
                                  NOT_TIMED)

    @property
    def n_robots(self) -> int:
        return len(self._seeds)

    @property
    def n_voxels(self) -> int:
        """V: the batch's most voxels (the width of an actuation)."""
        return self.system.voxel_corners.shape[1]

    @property
    def n_steps(self) -> int:
        """Control steps of the whole episode."""
        return self.config.n_steps

    @property
    def k(self) -> int:
        """Control steps taken (0 after start, ``n_steps`` at the end)."""
        return self._k

    @property
    def done(self) -> bool:
        return self._k >= self.n_steps

    def step(self, actuation: np.ndarray | None = None) -> Episode:
        """Advance every running robot one control step; returns the episode itself. One
        thread at a time: a step while another thread's runs is refused (the episode spreads
        its robots over threads of its own)."""
        if not self._stepping.acquire(blocking=False):
            raise bad("step", self._k + 1, "another thread is stepping this Episode now; step "
                      "an Episode from one thread at a time")
        try:
            return self._step(actuation)
        finally:
            self._stepping.release()

    def _step(self, actuation) -> Episode:
        if self.done:
            raise bad("step", self._k + 1, f"the episode has {self.n_steps} control steps")
        given = self._no_actuation
        if actuation is not None:
            given = real_array("actuation", actuation)
            expected = (self.n_robots, self.n_voxels)
            if given.shape != expected:
                raise bad("actuation", f"shape {given.shape}", f"must have shape {expected}")
            if not (np.abs(given) <= 1.0).all():  # NaN fails too
                raise bad("actuation", float(given.flat[np.argmax(~(np.abs(given) <= 1.0))]),
                          "every value must be in [-1, 1]")
            given = np.ascontiguousarray(given)
            if self._k == 0:
                # Step 0's actuation is 0 wherever a sequence runs (the compiled loop's
                # controllers have read nothing yet): checked, then not put in force.
                given = self._no_actuation
        self._k += 1
        step_in_groups(self._k, self._batch, self._groups, given, self._pool, self._threads)
        if self.done and self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        return self

    def run(self) -> Trace:
        """Step with the controllers to the end; the trace."""
        while not self.done:
            self.step()
        return self.trace

    @property
    def trace(self) -> Trace:
        """The trace so far (read-only views; steps not taken yet hold the initial values)."""
        return Trace(*(_read_only(a) for a in self._trace))

    @property
    def readings(self) -> np.ndarray:
        """(B, R) the sensors' normalised, noisy readings of the last step (padded: a robot's
        first ``n_readings`` columns)."""
        return _read_only(self._work.senses.readings)

    @property
    def actuation(self) -> np.ndarray:
        """(B, V) the actuation in force over the next step (the controllers' decision)."""
        return _read_only(self._work.brain.actuation)

    @property
    def positions(self) -> np.ndarray:
        """(B, P, 2) the voxel corners' positions [m] (a robot's first ``n_points`` rows)."""
        return _read_only(self._work.physics.pos)

    @property
    def com(self) -> np.ndarray:
        """(B, 2) the centre of mass [m] after the last step (NaN for a stopped robot's)."""
        return _read_only(self._trace.com[:, self._k])

    @property
    def status(self) -> np.ndarray:
        """(B,) int32 STATUS_* (:mod:`somite.tasks.episode`)."""
        return _read_only(self._trace.status)

    @property
    def diagnostics(self) -> np.ndarray:
        """(B, N_DIAGNOSTICS) the episode's D_* so far (:mod:`somite.tasks.episode`)."""
        return _read_only(self._trace.diagnostics)


__all__ = ["Episode", "real_array", "start_batch", "step_batch", "step_in_groups"]
