"""Viz output files: checking a path's extension and folder, and writing it all or nothing.

:func:`atomic_output` is used by every viz writer so that no output file is ever left
half-written.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path

from .._io import check_output_file
from ..errors import bad


def check_output(path: str | os.PathLike, formats: Sequence[str]) -> Path:
    """``path`` as a Path, or a one-line error if its extension or folder is wrong."""
    path = Path(path)
    if path.suffix.lower() not in formats:
        raise bad("out", str(path), f"unknown extension; use one of {list(formats)}")
    if not path.parent.is_dir():
        raise bad("out", str(path), "its folder does not exist")
    return check_output_file(path)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same extension); rename it onto ``path`` only
    when the block succeeds, otherwise delete it."""
    path = Path(path)
    tmp = path.parent / f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}{path.suffix}"
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


__all__ = [
    "atomic_output",
    "check_output",
]
