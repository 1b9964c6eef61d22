"""The environment variables that somite's libraries read at import, checked first.

Numba refuses ``NUMBA_NUM_THREADS=0`` and matplotlib an ``MPLBACKEND`` it does not know, each
with a traceback from deep inside an import; the command line checks them before anything
is imported and says so in one line (``somite: error: NUMBA_NUM_THREADS='0': ...``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping

from ..errors import bad

MAX_THREADS = 1024
"""The most threads ``NUMBA_NUM_THREADS`` may ask for: somite starts one thread per share of
a batch, so a value far past any machine's cores would start thousands."""


def check_environment(environ: Mapping[str, str] | None = None) -> None:
    """Refuse, in one line, an environment that a library would refuse with a traceback."""
    environ = os.environ if environ is None else environ
    threads = environ.get("NUMBA_NUM_THREADS")
    if threads is not None:
        text = threads.strip()
        if not (text.isascii() and text.isdigit()) or len(text) > 6:
            raise bad("NUMBA_NUM_THREADS", threads, "must be a whole number of threads, "
                      f"1 to {MAX_THREADS} (or unset: one a core)")
        if not 1 <= int(text) <= MAX_THREADS:
            raise bad("NUMBA_NUM_THREADS", threads, f"must be 1 to {MAX_THREADS} "
                      "(or unset: one a core)")
    backend = environ.get("MPLBACKEND")
    if backend:
        from ..viz.mplbackend import check_mplbackend

        check_mplbackend(backend)


__all__ = ["MAX_THREADS", "check_environment"]
