"""The one place for Numba compile options, and where compiled kernels are kept.

Every kernel of somite is compiled with ``cache=True`` (compiled code is reused across
processes), without fastmath (results must be reproducible bit for bit) and with Numba's numpy
error model (a division by zero gives inf/nan instead of raising inside a kernel).

**The cache is keyed on the kernels' sources.** Numba checks a cached function against its own
file only, not against the files of the functions it calls (numba/numba#8396), and somite's
kernels are assembled from ``sim/``, ``brain/``, ``tasks/`` and the foundation: an edit of a
helper in another file would otherwise leave the old machine code in use, with nothing to say
so. So before anything is compiled, this module points Numba's ``NUMBA_CACHE_DIR`` at a folder
named by a hash of those sources (:func:`kernel_sources`) and of the settings that change the
code generated: any edit gives a new folder, compiled afresh on first use. The folders live in
one place (:func:`cache_base`: the package's ``__pycache__/kernels``, else the
user's cache folder; inside ``NUMBA_CACHE_DIR``'s folder when the user set one). A process
holds a shared lock on its folder while it runs; each start removes the folders that no
running process holds, beyond the ``KEPT`` most recently used (so that switching back and forth
between two versions does not recompile every time). The CUDA backend caches nothing on disk
(``tasks/cuda_batch.py`` compiles in each process); were it to, it would use the same folder.
With ``NUMBA_DISABLE_JIT=1`` nothing is compiled and every kernel runs as Python (slowly, with
the same numbers: docs/architecture.md, "Debugging a kernel").

LLVM's SLP vectoriser, which Numba leaves off unless ``NUMBA_SLP_VECTORIZE`` says otherwise, is
turned on (unless that variable is set): it is what takes the joint passes of several robots
(:mod:`somite.sim.joint_lanes`) as vector instructions, several times faster than the same
arithmetic scalar (BENCHMARKS.md, "Robots as vector lanes"). It never reorders floating-point
arithmetic without fastmath, so no result changes. It applies to everything Numba compiles in
the process; set ``NUMBA_SLP_VECTORIZE=0`` to keep Numba's default (somite then runs slower,
with the same numbers). The setting is part of the cache folder's name, so kernels compiled
under one are never loaded under the other.
"""

import atexit
import functools
import hashlib
import os
import shutil
import sys
import tempfile
import types
from pathlib import Path

try:
    import fcntl
except ImportError:  # not on Windows: the folders are then kept, never pruned
    fcntl = None

import numba
from numba.core import config, sigutils
from numba.core.compiler_lock import global_compiler_lock
from numba.core.registry import CPUDispatcher

if "NUMBA_SLP_VECTORIZE" not in os.environ:
    # In the environment too: Numba re-reads its settings from it when a NUMBA_ variable
    # changes, which would otherwise turn the vectoriser off again.
    os.environ["NUMBA_SLP_VECTORIZE"] = "1"
    config.SLP_VECTORIZE = 1

PACKAGE = Path(__file__).resolve().parent
KERNEL_FLOORS = ("sim", "brain", "tasks")
"""The parts whose sources, with the modules at the package's top, make up the kernels: what a
kernel can call or read (the tasks floor and below, docs/architecture.md;
``tests/test_kernel_cache.py`` checks that no kernel reaches beyond them)."""

KEPT = 2
"""Cache folders kept besides the current one and those in use (the most recently used)."""

_MARK = "SOMITE_KERNEL_CACHE"
"""Environment variable naming the folder that somite (not the user) put in ``NUMBA_CACHE_DIR``:
a child process inherits both, and must still key the cache on its own sources."""

_LOCK = ".in-use"


def kernel_sources(package: Path = PACKAGE) -> list[Path]:
    """The files the kernels are compiled from: every module at the package's top and in
    ``KERNEL_FLOORS``, sorted."""
    files = list(package.glob("*.py"))
    for floor in KERNEL_FLOORS:
        files += (package / floor).rglob("*.py")
    return sorted(files)


def source_key(package: Path = PACKAGE) -> str:
    """A hash of :func:`kernel_sources` (names and contents) and of the code generator's
    settings that Numba's cache does not record."""
    digest = hashlib.sha256(f"slp={config.SLP_VECTORIZE};opt={config.OPT}\n".encode())
    for path in kernel_sources(package):
        digest.update(f"{path.relative_to(package).as_posix()}\n".encode())
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()[:16]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
        return True
    except OSError:
        return False


def cache_base() -> Path:
    """Where the per-source cache folders live: inside the user's ``NUMBA_CACHE_DIR`` if set
    (``somite-kernels``), else the package's ``__pycache__/kernels`` (beside Python's own
    caches, one per checkout), else the user's cache folder when the package is read-only."""
    chosen = os.environ.get("NUMBA_CACHE_DIR", "")
    if chosen and chosen == os.environ.get(_MARK):
        return Path(chosen).parent  # inherited from a somite process: its base
    if chosen:
        return Path(chosen) / "somite-kernels"
    inside = PACKAGE / "__pycache__" / "kernels"
    if _writable(inside):
        return inside
    home = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    user = Path(home) / "somite" / "kernels"
    if _writable(user):
        return user
    user_id = os.getuid() if hasattr(os, "getuid") else 0
    return Path(tempfile.gettempdir()) / f"somite-kernels-{user_id}"


_held = []  # the open lock file of this process's folder: a shared lock, held until exit


def _hold(folder: Path) -> None:
    """Take a shared lock on ``folder``'s lock file (a pruning process needs an exclusive one)
    and mark it used now; retried if a pruning process removed the folder meanwhile."""
    for _ in range(10):
        folder.mkdir(parents=True, exist_ok=True)
        try:
            handle = open(folder / _LOCK, "a")
        except OSError:
            continue
        fcntl.flock(handle, fcntl.LOCK_SH)
        try:
            same = os.stat(folder / _LOCK).st_ino == os.fstat(handle.fileno()).st_ino
        except OSError:
            same = False
        if same:
            os.utime(folder / _LOCK)
            _held.append(handle)
            atexit.register(handle.close)  # released at exit, without Python's warning
            return
        handle.close()


def prune(base: Path, current: Path, kept: int = KEPT) -> list[Path]:
    """Remove the cache folders in ``base`` that no process holds, but ``current`` and the
    ``kept`` most recently used; the folders removed."""
    if fcntl is None or not base.is_dir():
        return []

    def used(folder: Path) -> float:
        try:
            return (folder / _LOCK).stat().st_mtime
        except OSError:
            return folder.stat().st_mtime

    others = sorted((f for f in base.iterdir() if f.is_dir() and f != current), key=used,
                    reverse=True)
    removed = []
    for folder in others[kept:]:
        try:
            handle = open(folder / _LOCK, "a")
        except OSError:
            continue
        with handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                continue  # a running process compiled from these sources holds it
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def _use_source_keyed_cache() -> Path:
    base = cache_base()
    folder = base / source_key()
    # The environment too: Numba re-reads its settings from it when a NUMBA_ variable changes.
    os.environ["NUMBA_CACHE_DIR"] = os.environ[_MARK] = str(folder)
    config.CACHE_DIR = str(folder)
    if fcntl is not None:
        try:
            _hold(folder)
            prune(base, folder)
        except OSError:
            pass  # a cache that cannot be tidied still works
    return folder


KERNEL_CACHE = _use_source_keyed_cache()
"""This process's cache folder (``NUMBA_CACHE_DIR``)."""

OPTIONS = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True}


def uncounted(function):
    """:func:`njit` without Numba's reference counting (its private option ``_nrt=False``),
    for kernels that allocate nothing: every array view they take would otherwise cost an
    atomic increment and decrement of a counter that other threads' robots share (the batch
    kernel ran 10-15% slower on 2 threads). Such a kernel must take its views from functions
    compiled the same way or inlined into it (``tasks.episode.uncounted_work_row``)."""
    return njit(_nrt=False)(function)


def njit(*args, **kwargs):
    """``numba.njit`` with somite's options; ``parallel=True`` may be passed for prange kernels.
    Its compiles wait for another process's compile of the same kernel (:func:`_one_at_a_time`)."""
    options = {**OPTIONS, **kwargs}
    if args and callable(args[0]):
        return _one_at_a_time(numba.njit(**options)(args[0]))
    return lambda function: _one_at_a_time(numba.njit(**options)(function))


def _one_at_a_time(kernel):
    """``kernel`` (a dispatcher) whose compiles hold a lock on a file of :data:`KERNEL_CACHE`
    named after it: processes that need the same kernel on a cold cache (test workers, a
    campaign's workers, :mod:`somite.tasks.warm`'s second process) then compile it once, and the
    others load it from the cache once the first is done, instead of each spending minutes on
    the same compile. A callee's compile (inside its caller's) takes its own lock too, so two
    processes compiling one call tree from different ends share its kernels; they cannot wait
    on each other, as a process holds only the locks of the kernels it is inside, and no kernel
    calls its callers."""
    if fcntl is None or not isinstance(kernel, CPUDispatcher):
        return kernel  # NUMBA_DISABLE_JIT: nothing is compiled
    compile_now = kernel.compile
    name = f".compiling-{kernel.py_func.__module__}.{kernel.py_func.__qualname__}"

    @functools.wraps(compile_now)
    def compile_waiting(sig):
        if _compiled_here(kernel, sig):
            # Typing asks again at every call site of a compiled callee.
            return compile_now(sig)
        # Numba's own lock first, as its compile of a caller takes it before a callee's file
        # lock: two threads of this process then never hold one each and wait for the other.
        with global_compiler_lock:
            try:
                lock = open(KERNEL_CACHE / name, "a")
            except OSError:
                return _compile_unsaved_if_need_be(compile_now, sig)
            with lock:
                fcntl.flock(lock, fcntl.LOCK_EX)
                # The lock goes with the file's closing.
                return _compile_unsaved_if_need_be(compile_now, sig)

    # Numba calls the instance's ``compile`` for a kernel's first call and for a callee's.
    kernel.compile = compile_waiting
    return kernel


def _compiled_here(kernel, sig) -> bool:
    try:
        args, _ = sigutils.normalize_signature(sig)
    except (TypeError, ValueError):
        return False
    return tuple(args) in kernel.overloads


def _compile_unsaved_if_need_be(compile_now, sig):
    try:
        return compile_now(sig)
    except OSError:
        # Numba adds the compiled code to the kernel before it writes it to the cache: a cache
        # that cannot be written (a full disk, a file size limit) costs a compile next time,
        # not this run. Asked again, Numba returns that code (an error of its own recurs).
        return compile_now(sig)


@functools.cache
def device_twin(kernel):
    """The CUDA device function compiled from the same Python source as ``kernel`` (a
    function decorated with :func:`njit`): the functions it calls are replaced by their own
    twins, so one source serves both backends. Needs numba-cuda; under its simulator
    (``NUMBA_ENABLE_CUDASIM=1``) the twin runs as plain Python."""
    from numba import cuda

    source = getattr(kernel, "py_func", kernel)  # the function itself under NUMBA_DISABLE_JIT
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
    """Whether Numba's on-disk cache holds a compiled ``kernel`` (an :func:`njit` function)
    for the present sources: its index file in :data:`KERNEL_CACHE`, as Numba names it (True
    under ``NUMBA_DISABLE_JIT``: nothing will compile). None when that cannot be told."""
    code = getattr(kernel, "py_func", kernel).__code__
    if not isinstance(kernel, CPUDispatcher):
        return True if config.DISABLE_JIT else None
    cache = getattr(kernel, "_cache", None)
    folder = getattr(cache, "cache_path", None)
    if folder is None:
        return None
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    stem = Path(code.co_filename).stem
    name = f"{stem}.{kernel.py_func.__qualname__}-{code.co_firstlineno}.{tag}.nbi"
    return (Path(folder) / name).is_file()
