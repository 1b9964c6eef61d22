"""Viz output files: checking a path's extension and folder, and writing it all or nothing.

:func:`atomic_output` is used by every viz writer so that no output file is ever left
half-written, and a failed write (a full disk, a target that cannot be replaced) is one line.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path

from .._io import check_output_file, check_path_length, discard, reason
from ..errors import bad


def check_output(path: str | os.PathLike, formats: Sequence[str]) -> Path:
    """``path`` as a Path, or a one-line error if its extension or folder is wrong, if it
    exists and cannot be replaced (read-only) or if its name is too long."""
    path = Path(path)
    if path.suffix.lower() not in formats:
        raise bad("out", str(path), f"unknown extension; use one of {list(formats)}")
    check_path_length(path, "out", temporary=True)
    try:
        folder = path.parent.is_dir()
    except OSError as error:  # a folder above that cannot be searched
        raise bad("out", str(path), f"cannot use it ({reason(error)})") from None
    if not folder:
        raise bad("out", str(path), "its folder does not exist")
    return check_output_file(path)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, field: str = "out") -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same extension); rename it onto ``path`` only
    when the block succeeds, otherwise delete it. An OSError in the block or the rename (a
    full disk, a target that cannot be replaced) is a one-line error naming ``field``, the
    file and the OS's reason; ``path`` is then left as it was."""
    path = Path(path)
    tmp = path.parent / f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}{path.suffix}"
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException as error:
        discard(tmp)
        if isinstance(error, OSError):
            raise bad(field, str(path), f"cannot write it ({reason(error)})") from None
        raise


__all__ = [
    "atomic_output",
    "check_output",
]
