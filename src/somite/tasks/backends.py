"""Where a batch of episodes runs: ``cpu`` (Numba, robots over the cores) or ``cuda`` (one GPU
thread per robot, :mod:`somite.tasks.cuda_batch`). Both run the same episode code."""

from __future__ import annotations

import os

from ..errors import bad

BACKENDS = ("cpu", "cuda")


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


def check_backend(backend: str) -> str:
    """``backend`` if it can run here, else a one-line error naming it."""
    if backend not in BACKENDS:
        raise bad("backend", backend, f"use one of {list(BACKENDS)}")
    if backend == "cuda":
        reason = cuda_unavailable()
        if reason:
            raise bad("backend", backend, reason)
    return backend
