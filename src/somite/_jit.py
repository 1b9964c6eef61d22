"""The one place for Numba compile options.

Every kernel of somite is compiled with ``cache=True`` (compiled code is reused across
processes), without fastmath (results must be reproducible bit for bit) and with Numba's numpy
error model (a division by zero gives inf/nan instead of raising inside a kernel).
"""

import numba

_OPTIONS = {"cache": True, "fastmath": False, "error_model": "numpy", "nogil": True}


def njit(*args, **kwargs):
    """``numba.njit`` with somite's options; ``parallel=True`` may be passed for prange kernels."""
    options = {**_OPTIONS, **kwargs}
    if args and callable(args[0]):
        return numba.njit(**options)(args[0])
    return numba.njit(**options)
