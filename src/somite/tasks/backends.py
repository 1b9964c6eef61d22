"""Where a batch of episodes runs: the registry of backends, :data:`BACKENDS`.

Each backend is a batch runner with the signature of :func:`somite.tasks.lanes.run_batch`
(it fills a host :class:`~somite.tasks.episode.Trace`), a check of whether it can run here and
its line of ``--backend`` help. ``cpu`` runs the robots over the cores (Numba); ``cuda`` runs
one GPU thread per robot (:mod:`somite.tasks.cuda_batch`). Both run the same episode code.

Adding a backend is one entry here (the command line's help and the tests read the registry).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass

from ..errors import bad


@dataclass(frozen=True)
class Backend:
    """A batch runner: ``run(system, controllers, params, noise, seeds, n_steps, trace)``;
    ``unavailable()`` says why it cannot run here (None when it can); ``records``: it can
    fill a recording trace (every step's positions, ...)."""

    run: Callable
    unavailable: Callable[[], str | None]
    records: bool
    help: str


def _run_on_cpu(system, controllers, params, noise, seeds, n_steps, trace) -> None:
    # Imported when run: the command line reads this registry for its help, without Numba.
    from .lanes import run_batch

    run_batch(system, controllers, params, noise, seeds, n_steps, trace)


def _run_on_gpu(system, controllers, params, noise, seeds, n_steps, trace) -> None:
    # Imported when run: importing it compiles CUDA code, which needs numba-cuda.
    from .cuda_batch import run_batch

    run_batch(system, controllers, params, noise, seeds, n_steps, trace)


def cuda_unavailable() -> str | None:
    """Why the ``cuda`` backend cannot run here, or None when it can (a GPU and numba-cuda,
    or numba-cuda's simulator under ``NUMBA_ENABLE_CUDASIM=1``)."""
    try:
        from numba import cuda
    except ImportError:  # pragma: no cover - numba without its CUDA target
        return "numba-cuda is not installed (pip install somite[cuda])"
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return None
    try:
        import numba_cuda  # noqa: F401
    except ImportError:
        return "numba-cuda is not installed (pip install somite[cuda])"
    if not cuda.is_available():
        return "no CUDA GPU or driver found"
    return None


BACKENDS: dict[str, Backend] = {
    "cpu": Backend(_run_on_cpu, lambda: None, records=True, help="the CPU's cores (default)"),
    "cuda": Backend(
        _run_on_gpu,
        cuda_unavailable,
        records=False,
        help="an NVIDIA GPU (pip install somite[cuda])",
    ),
}
"""Backend name -> :class:`Backend`."""


def backend_help() -> str:
    """The ``--backend`` option's help: every registered backend."""
    listed = "; ".join(f"{name}, {b.help}" for name, b in BACKENDS.items())
    return f"where episodes run, not part of a run's configuration: {listed}"


def get_backend(name: str) -> Backend:
    """The backend ``name`` if it can run here, else a one-line error naming it."""
    backend = BACKENDS.get(name)
    if backend is None:
        raise bad("backend", name, f"use one of {list(BACKENDS)}")
    reason = backend.unavailable()
    if reason:
        raise bad("backend", name, reason)
    return backend


def check_backend(name: str) -> str:
    """``name`` if that backend can run here, else a one-line error naming it."""
    get_backend(name)
    return name


__all__ = [
    "BACKENDS",
    "Backend",
    "backend_help",
    "check_backend",
    "cuda_unavailable",
    "get_backend",
]
