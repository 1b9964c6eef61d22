"""Atomic file writing: a file is either its old self or complete, never half-written."""

from __future__ import annotations

import os
import uuid
from pathlib import Path


def write_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    # Not tempfile.mkstemp: its files are private (0600); os.open with 0666 honours the umask.
    tmp = path.parent / f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp"
    handle = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException:
        # Never leave a half-written temp file beside the real ones.
        tmp.unlink(missing_ok=True)
        raise
    return path


def _nearest_existing(path: Path) -> Path:
    for candidate in (path, *path.parents):
        if candidate.exists() or candidate.is_symlink():
            return candidate
    return Path(".")


def _check_creatable(path: Path, field: str) -> None:
    """Refuse ``path`` (to be created) when the folder it would be created in cannot be."""
    from .errors import bad

    above = _nearest_existing(path.parent if path.parent != path else path)
    if above.is_symlink() and not above.exists():
        raise bad(field, str(path), f"{above} is a dangling symbolic link")
    if not above.is_dir():
        raise bad(field, str(path), f"{above} is not a folder")
    if not os.access(above, os.W_OK | os.X_OK):
        raise bad(field, str(path), f"cannot write in {above} (permission denied or read-only)")


def check_output_folder(path: str | os.PathLike, field: str = "out") -> Path:
    """An output folder that exists (writable) or can be created, or a one-line error;
    checked before any work, so that no run ends in a traceback when it saves."""
    from .errors import bad

    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise bad(field, str(path), "is a dangling symbolic link")
    if path.exists():
        if not path.is_dir():
            raise bad(field, str(path), "exists and is not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise bad(field, str(path), "cannot write in it (permission denied or read-only)")
        return path
    _check_creatable(path, field)
    return path


def check_output_file(path: str | os.PathLike, field: str = "out") -> Path:
    """An output file that can be written (replaced, if it exists), or a one-line error."""
    from .errors import bad

    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise bad(field, str(path), "is a dangling symbolic link")
    if path.is_dir():
        raise bad(field, str(path), "is a folder; give the file to write")
    if path.exists() and not path.is_file():
        raise bad(field, str(path), "exists and is not a regular file")
    if path.parent.exists():
        check_output_folder(path.parent, field)
    else:
        _check_creatable(path.parent, field)
    return path
