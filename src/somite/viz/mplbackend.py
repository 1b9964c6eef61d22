"""matplotlib's ``MPLBACKEND``, checked: matplotlib refuses a name it does not know when it is
imported, with a traceback; somite draws into files (the Agg canvas, no pyplot) and needs no
backend at all."""

from __future__ import annotations

from ..errors import bad


def check_mplbackend(name: str) -> None:
    """Refuse ``name`` (the value of ``MPLBACKEND``) in one line if matplotlib refuses it."""
    try:
        import matplotlib  # noqa: F401 - reads MPLBACKEND when imported
    except ValueError:
        raise bad("MPLBACKEND", name, "not a backend matplotlib knows; somite draws into "
                  "files and needs none: unset it (or set it to agg)") from None


__all__ = ["check_mplbackend"]
