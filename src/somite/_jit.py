"""The one place for Numba compile options.

Every kernel of somite is compiled with ``cache=True`` (compiled code is reused across
processes), without fastmath (results must be reproducible bit for bit) and with Numba's numpy
error model (a division by zero gives inf/nan instead of raising inside a kernel).

LLVM's SLP vectoriser, which Numba leaves off unless ``NUMBA_SLP_VECTORIZE`` says otherwise, is
turned on (unless that variable is set): it is what takes the joint passes of several robots
(:mod:`somite.sim.joint_lanes`) as vector instructions, several times faster than the same
arithmetic scalar (BENCHMARKS.md, "Robots as vector lanes"). It never reorders floating-point
arithmetic without fastmath, so no result changes. It applies to everything Numba compiles in
the process; set ``NUMBA_SLP_VECTORIZE=0`` to keep Numba's default (somite then runs slower,
with the same numbers). Numba's cache does not record the setting: kernels compiled under one
are loaded under the other until the cache is deleted.
"""

import functools
import os
import types

import numba
from numba.core import config
from numba.core.registry import CPUDispatcher

if "NUMBA_SLP_VECTORIZE" not in os.environ:
    # In the environment too: Numba re-reads its settings from it when a NUMBA_ variable
    # changes, which would otherwise turn the vectoriser off again.
    os.environ["NUMBA_SLP_VECTORIZE"] = "1"
    config.SLP_VECTORIZE = 1

OPTIONS = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True}


def uncounted(function):
    """:func:`njit` without Numba's reference counting (its private option ``_nrt=False``),
    for kernels that allocate nothing: every array view they take would otherwise cost an
    atomic increment and decrement of a counter that other threads' robots share (the batch
    kernel ran 10-15% slower on 2 threads). Such a kernel must take its views from functions
    compiled the same way or inlined into it (``tasks.episode.uncounted_work_row``)."""
    return njit(_nrt=False)(function)


def njit(*args, **kwargs):
    """``numba.njit`` with somite's options; ``parallel=True`` may be passed for prange kernels."""
    options = {**OPTIONS, **kwargs}
    if args and callable(args[0]):
        return numba.njit(**options)(args[0])
    return numba.njit(**options)


@functools.cache
def device_twin(kernel):
    """The CUDA device function compiled from the same Python source as ``kernel`` (a
    function decorated with :func:`njit`): the functions it calls are replaced by their own
    twins, so one source serves both backends. Needs numba-cuda; under its simulator
    (``NUMBA_ENABLE_CUDASIM=1``) the twin runs as plain Python."""
    from numba import cuda

    source = kernel.py_func
    names = dict(source.__globals__)
    for name in source.__code__.co_names:
        value = names.get(name)
        # A phase of the physics step (sim/step.py) resolves by the solver's type on the CPU;
        # on the device, where a thread runs one robot, it is that robot's implementation.
        on_device = getattr(value, "on_device", None)
        if on_device is not None:
            names[name] = device_twin(on_device)
        elif isinstance(value, CPUDispatcher):
            names[name] = device_twin(value)
    twin = types.FunctionType(source.__code__, names, source.__name__, source.__defaults__,
                              source.__closure__)
    twin.__qualname__ = source.__qualname__
    twin.__module__ = source.__module__
    return cuda.jit(device=True)(twin)


def on_disk(kernel) -> bool | None:
    """Whether Numba's on-disk cache holds a compiled ``kernel`` (an :func:`njit` function):
    its index file in the ``__pycache__`` beside the source, as Numba names it. None when
    that cannot be told (``NUMBA_CACHE_DIR`` moves the cache elsewhere). An index can be
    stale after an edit, so True means "probably compiled"; it serves a message only."""
    import os
    import sys
    from pathlib import Path

    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    code = kernel.py_func.__code__
    source = Path(code.co_filename)
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    name = f"{source.stem}.{kernel.py_func.__qualname__}-{code.co_firstlineno}.{tag}.nbi"
    return (source.parent / "__pycache__" / name).is_file()
