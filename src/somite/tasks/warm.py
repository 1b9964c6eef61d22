"""The first compile on two cores: a second process compiles the physics of a group while
this one compiles the one-robot step and the rest of the batch kernel.

Numba compiles a kernel and everything it calls in one thread, and nearly all of the first
compile is the CPU batch kernel's call tree (BENCHMARKS.md, "The first compile, kernel by
kernel"). Its kernels are cached one by one, and each compile holds a lock named after its
kernel (``_jit._one_at_a_time``): a process that reaches a kernel another is compiling waits for
it and loads it from the cache. So on a cold cache :func:`share_first_compile` starts a process
that compiles the control step's views of a robot's arrays
(:func:`~somite.tasks.episode.uncounted_work_row`) and :func:`~somite.sim.group.advance_group`
for this batch's types (the lane passes and the group's phases first), while this process
compiles the position passes (the last the other reaches) and :func:`somite.sim.physics.advance`
(a group of one: the one-robot step and the contact search, which the group's phases call too),
then :func:`~somite.tasks.lanes.run_group`, which finds the group's physics in the cache or
waits for it. The numbers are the same whichever process compiled a kernel: it is the same code.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

from numba import typeof, types

from .._jit import PACKAGE, fcntl, on_disk
from ..sim import joint_lanes as jl
from ..sim import physics as ph
from ..sim.group import NOT_TIMED, advance_group, new_group
from .episode import robot_state, uncounted_work_row, work_row

_CHILD = "from somite.tasks.warm import compile_from_stdin; compile_from_stdin()"


def _shared_cores() -> bool:
    try:
        return len(os.sched_getaffinity(0)) > 1
    except AttributeError:  # not on Linux
        return (os.cpu_count() or 1) > 1


def physics_signature(batch, first, count) -> tuple:
    """The argument types that ``run_group`` calls ``advance_group`` with for ``batch``'s first
    group (``first``, ``count``: :func:`~somite.sim.group.groups`), and that group."""
    bodies = batch.work.physics
    b = int(first[0])
    # new_group's own code, run as Python, gives a Group of the types the kernel makes.
    group = new_group.py_func(batch.system, first[0], count[0],
                              (bodies.inv_mass[b], bodies.inv_inertia[b]), NOT_TIMED)
    return (typeof(batch.system), typeof(bodies), typeof(batch.params), typeof(group),
            types.int64), group


def alone_signature(batch) -> tuple:
    """The argument types that ``advance_group`` calls :func:`somite.sim.physics.advance` with
    for ``batch``: a robot's build and state as ``run_group`` types them (its ``robot_state``
    of a ``work_row``, compiled here, as ``run_group`` needs them too; ``advance_group`` takes
    the same views of the same arrays), not as Python sees them (its counts are the system's
    int32, a Python int is int64)."""
    system, ctrl, params = typeof(batch.system), typeof(batch.ctrl), typeof(batch.params)
    row = (typeof(batch.work), types.int64, system, ctrl, params)
    work_row.compile(row)
    work = work_row.overloads[row].signature.return_type
    state_args = (system, types.int64, params, work, typeof(batch.rays))
    robot_state.compile(state_args)
    state = dict(zip(*_fields(robot_state.overloads[state_args].signature.return_type)))
    body = dict(zip(*_fields(state["work"])))["physics"]
    return state["robot"], state["ground"], body, params, types.int64


def _fields(named_tuple_type) -> tuple:
    return named_tuple_type.fields, named_tuple_type.types


def share_first_compile(batch, first, count) -> subprocess.Popen | None:
    """On a cold cache and more than one core: the process compiling ``advance_group`` for
    ``batch``'s types (None when there is nothing to share), once this process has compiled
    the position passes and ``physics.advance`` meanwhile. A process that fails to start or to
    compile leaves its work to this one."""
    if fcntl is None or on_disk(advance_group) is not False or not _shared_cores():
        return None
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(PACKAGE.parent)] + [
        p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    signature, group = physics_signature(batch, first, count)
    try:
        child = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        child.stdin.write(pickle.dumps((row_signature(batch), signature)))
        child.stdin.close()
    except (OSError, pickle.PicklingError):
        return None
    # The position passes are the last lane passes the child reaches (its group's phases in
    # their order): this process takes them off its hands first.
    jl.fix_joints.compile((typeof(group.lanes), typeof(group.flags)))
    ph.advance.compile(alone_signature(batch))
    return child


def row_signature(batch) -> tuple:
    """The argument types that the control step calls ``uncounted_work_row`` with."""
    return (typeof(batch.work), types.int64, typeof(batch.system), typeof(batch.ctrl),
            typeof(batch.params))


def compile_from_stdin() -> None:
    """The second process: ``uncounted_work_row`` and ``advance_group`` compiled for the
    pickled signatures on stdin. The row views first: this process reaches them in the control
    step before the group's physics is done, and would otherwise compile them itself."""
    row, physics = pickle.loads(sys.stdin.buffer.read())
    uncounted_work_row.compile(row)
    advance_group.compile(physics)


def finish_sharing(child: subprocess.Popen | None, at_once: bool = False) -> None:
    """Wait for the second process (done or nearly: the kernel needed what it compiled), or
    end it after a minute, or ``at_once`` (the batch failed or was interrupted)."""
    if child is None:
        return
    try:
        child.wait(timeout=0 if at_once else 60)
    except subprocess.TimeoutExpired:
        child.kill()
        child.wait()
