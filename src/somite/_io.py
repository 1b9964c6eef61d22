"""Atomic file writing: a file is either its old self or complete, never half-written."""

from __future__ import annotations

import csv
import errno
import io
import json
import math
import os
import re
import stat
import sys
import tempfile
import tomllib
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from .errors import bad
from .limits import MAX_INPUT_BYTES

TEMPORARY = re.compile(r"\.(?P<name>.+)\.\d+\.[0-9a-f]{8}\.tmp")
"""The name of :func:`write_atomic`'s temporary file: ``.NAME.PID.RAND.tmp``."""


def temporary_name(name: str) -> str:
    """The name of :func:`write_atomic`'s temporary file beside the file ``name``."""
    return f".{name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp"


def json_safe(value):
    """``value`` with NaN and infinities as None (JSON's ``null``), in dicts, lists and tuples:
    what every JSON somite writes goes through (``NaN`` is not JSON)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def csv_text(columns: Sequence[str], rows: Iterable) -> str:
    """CSV text, the header ``columns`` then ``rows`` (each a sequence in the columns' order,
    or a mapping read by them: other keys ignored, a missing one empty), lines ending in
    ``\n``, None as an empty field: every CSV file somite writes, so that they read alike."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([row.get(c) for c in columns] if isinstance(row, Mapping) else row)
    return buffer.getvalue()


def write_atomic(path: str | os.PathLike, text: str | bytes, field: str = "out") -> Path:
    """Write ``text`` (UTF-8; or ``bytes`` as they are) to ``path`` through a temporary file in
    the same folder and a rename.

    Any OSError (creating, writing, flushing or renaming: a full disk, a read-only or immutable
    target, a folder that went away, a name too long) is a one-line error naming ``field``
    and the OS's reason; the temporary file is removed and the old ``path`` left as it was."""
    path = Path(path)
    data = text if isinstance(text, bytes) else text.encode("utf-8")
    # Not tempfile.mkstemp: its files are private (0600); os.open with 0666 honours the umask.
    tmp = path.parent / temporary_name(path.name)
    try:
        handle = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as error:
        raise _cannot_write(path, error, field) from None
    try:
        try:
            _write_all(handle, data)
            os.fsync(handle)
        finally:
            os.close(handle)
        os.replace(tmp, path)
    except BaseException as error:
        # Never leave a half-written temp file beside the real ones.
        discard(tmp)
        if isinstance(error, OSError):  # a full disk, a folder that went away, ...
            raise _cannot_write(path, error, field) from None
        raise
    return path


def _write_all(handle: int, data: bytes) -> None:
    """``os.write`` until all of ``data`` is written (a write may take only part of it)."""
    view = memoryview(data)
    while view:
        written = os.write(handle, view)
        if written <= 0:  # no progress and no error: treat as a full disk, not a hang

            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        view = view[written:]


def discard(path: Path) -> None:
    """Delete ``path`` if it is there, quietly: called while another error is on its way."""
    try:
        path.unlink(missing_ok=True)
    except OSError:
        pass


def reason(error: OSError) -> str:
    """An OSError's reason in a few words, on one line: its strerror (``No space left on
    device``), else the first line of its message (a library's, that may hold many)."""
    if error.strerror:
        return error.strerror
    lines = str(error).strip().splitlines()
    return lines[0] if lines else type(error).__name__


def remove_temporary(folder: str | os.PathLike) -> None:
    """Delete the temporary files of :func:`write_atomic` that writers killed between write
    and rename left in ``folder`` (not its subfolders). Call it only where no live writer can
    own them, e.g. before a task redoes the work of a killed attempt."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for path in folder.iterdir():
        if TEMPORARY.fullmatch(path.name) and path.is_file() and not path.is_symlink():
            path.unlink(missing_ok=True)


def _cannot_write(path: Path, error: OSError, field: str = "out"):
    return bad(field, str(path), f"cannot write it ({reason(error)})")


def make_folder(path: str | os.PathLike, field: str = "out") -> Path:
    """``mkdir -p`` an output folder, or a one-line error naming ``field``."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise bad(field, str(path), f"cannot create it ({error.strerror or error})") from None
    return path


CHECK_PREFIX = ".somite-check."
"""The name of the file :func:`_try_writing` creates and deletes at once (a kill may leave it)."""


def _try_writing(folder: Path, field: str, shown: Path) -> None:
    """Create and delete a file in ``folder``: ``os.access`` does not know every refusal (root
    in /proc or /sys, some network file systems), a try does."""
    try:
        handle, name = tempfile.mkstemp(prefix=CHECK_PREFIX, dir=folder)
    except OSError as error:
        raise bad(field, str(shown), f"cannot write in {folder} ({error.strerror or error})"
                  ) from None
    os.close(handle)
    os.unlink(name)


def _nearest_existing(path: Path) -> Path:
    for candidate in (path, *path.parents):
        if candidate.exists() or candidate.is_symlink():
            return candidate
    return Path(".")


def _check_creatable(path: Path, field: str) -> None:
    """Refuse ``path`` (to be created) when the folder it would be created in cannot be."""
    above = _nearest_existing(path.parent if path.parent != path else path)
    if above.is_symlink() and not above.exists():
        raise bad(field, str(path), f"{above} is a dangling symbolic link")
    if not above.is_dir():
        raise bad(field, str(path), f"{above} is not a folder")
    if not os.access(above, os.W_OK | os.X_OK):
        raise bad(field, str(path), f"cannot write in {above} (permission denied or read-only)")
    _try_writing(above, field, path)


def _limits(path: Path) -> tuple[int, int]:
    """NAME_MAX and PATH_MAX of the file system ``path`` is (or would be created) on, from
    its nearest existing folder; 255 and 4096 (Linux's) where the system does not say, 0
    where it sets no limit."""
    for candidate in (path, *path.parents):
        try:
            os.lstat(candidate)
        except OSError:  # missing, or itself too long: look further up
            continue
        try:
            limits = os.pathconf(candidate, "PC_NAME_MAX"), os.pathconf(candidate, "PC_PATH_MAX")
        except (OSError, ValueError, AttributeError):  # a dangling link, no pathconf
            break
        return tuple(max(0, limit or 0) for limit in limits)
    return 255, 4096


def check_path_length(path: str | os.PathLike, field: str = "out",
                      temporary: bool = False) -> Path:
    """Refuse, in one line, a path the system would refuse as too long (ENAMETOOLONG): a name
    in it longer than the file system's NAME_MAX, or the whole longer than PATH_MAX; with
    ``temporary``, counting the temporary file a write puts beside the file
    (:func:`temporary_name`, the longest the writers use)."""
    path = Path(path)
    name_max, path_max = _limits(path)
    extra = 0
    if temporary:
        name = len(os.fsencode(path.name))
        extra = len(os.fsencode(temporary_name(path.name))) - name
        if name_max and name + extra > name_max:
            raise bad(field, str(path), f"its name is too long for the file system ({name} "
                      f"bytes, and the temporary file written beside it adds {extra}; at most "
                      f"{name_max - extra})")
    for part in path.parts:
        size = len(os.fsencode(part))
        if name_max and size > name_max and part != path.anchor:
            raise bad(field, str(path), f"a name in it is too long for the file system "
                      f"({size} bytes; at most {name_max})")
    whole = len(os.fsencode(str(path))) + extra
    if path_max and whole >= path_max:
        counted = " with the temporary file" if extra else ""
        raise bad(field, str(path), f"the path is too long for the system ({whole} bytes"
                  f"{counted}; at most {path_max - 1})")
    return path


def _cannot_check(path: Path, field: str, error: OSError):
    return bad(field, str(path), f"cannot use it ({reason(error)})")


def check_output_folder(path: str | os.PathLike, field: str = "out") -> Path:
    """An output folder that exists (writable) or can be created, or a one-line error;
    checked before any work, so that no run ends in a traceback when it saves."""
    path = check_path_length(path, field)
    try:
        return _check_output_folder(path, field)
    except OSError as error:  # a folder above that cannot be searched, ...
        raise _cannot_check(path, field, error) from None


def _check_output_folder(path: Path, field: str) -> Path:
    if path.is_symlink() and not path.exists():
        raise bad(field, str(path), "is a dangling symbolic link")
    if path.exists():
        if not path.is_dir():
            raise bad(field, str(path), "exists and is not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise bad(field, str(path), "cannot write in it (permission denied or read-only)")
        _try_writing(path, field, path)
        return path
    _check_creatable(path, field)
    return path


def check_output_file(path: str | os.PathLike, field: str = "out") -> Path:
    """An output file that can be written (replaced, if it exists), or a one-line error: a
    folder, a special file, a dangling link, a folder that cannot be written in or created,
    an existing file that is read-only (or immutable: it is not replaced), a name too long."""
    path = check_path_length(path, field, temporary=True)
    try:
        return _check_output_file(path, field)
    except OSError as error:
        raise _cannot_check(path, field, error) from None


def _check_output_file(path: Path, field: str) -> Path:
    if path.is_symlink() and not path.exists():
        raise bad(field, str(path), "is a dangling symbolic link")
    if path.is_dir():
        raise bad(field, str(path), "is a folder; give the file to write")
    if path.exists() and not path.is_file():
        raise bad(field, str(path), "exists and is not a regular file")
    if path.is_file() and not os.access(path, os.W_OK):
        # os.replace would replace a read-only file (the folder decides), but not an
        # immutable one; either way its owner asked for it to be kept.
        raise bad(field, str(path), "exists and is read-only; it is not replaced (make it "
                  "writable, or give another file)")
    if path.parent.exists():
        _check_output_folder(path.parent, field)
    else:
        _check_creatable(path.parent, field)
    return path


def tail_lines(path: str | os.PathLike, size: int, skip: int = 0) -> list[str]:
    """The whole lines among the last ``size`` bytes of a file that is being appended to,
    after its first ``skip`` bytes (a header read apart): a line the tail cuts at its start is
    dropped; the last one may still be being written, which the caller checks. Raises
    OSError."""
    with open(path, "rb") as handle:
        end = handle.seek(0, os.SEEK_END)
        start = max(skip, end - size)
        handle.seek(start)
        lines = handle.read().decode(errors="replace").splitlines()
    return lines[1:] if start > skip else lines


def read_text(path: str | os.PathLike, field: str) -> str:
    """The UTF-8 text of the regular file ``path``, or a one-line error naming ``field``: no
    such file, a folder or a FIFO (whose read would wait forever), larger than
    :data:`~somite.limits.MAX_INPUT_BYTES`, not UTF-8."""
    path = Path(path)
    try:
        info = os.stat(path)
    except OSError as error:
        raise bad(field, str(path), f"cannot read the file ({error.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a folder" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise bad(field, str(path), f"is {kind}")
    if info.st_size > MAX_INPUT_BYTES:
        raise bad(field, str(path), f"larger than {MAX_INPUT_BYTES // 2**20} MiB")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_INPUT_BYTES + 1)
    except OSError as error:
        raise bad(field, str(path), f"cannot read the file ({error.strerror})") from None
    if len(data) > MAX_INPUT_BYTES:
        raise bad(field, str(path), f"larger than {MAX_INPUT_BYTES // 2**20} MiB")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise bad(field, str(path), f"not UTF-8 text ({error.reason} at byte {error.start})"
                  ) from None


def _why(error: ValueError) -> str:
    """A parser's ValueError in a few words: Python's int-string limit's message is long."""
    message = str(error)
    if "integer string conversion" in message:
        return f"an integer of more than {sys.get_int_max_str_digits()} digits"
    return message


class _DuplicateKey(ValueError):
    pass


def _no_duplicates(pairs: list) -> dict:
    """A JSON object's pairs as a dict; a key twice is refused (json keeps the last one, so a
    trailing ``"edges": []`` would silently drop every edge before it)."""
    data = dict(pairs)
    if len(data) != len(pairs):
        seen = set()
        twice = next(key for key, _ in pairs if key in seen or seen.add(key))
        raise _DuplicateKey(f"the key {twice!r} appears twice in one object")
    return data


def parse_json(text: str, field: str, where: str):
    """JSON ``text`` or a one-line error: invalid, nested too deeply, an integer too long, a
    key given twice in one object."""
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except _DuplicateKey as error:
        raise bad(field, where, f"not valid somite JSON ({error})") from None
    except RecursionError:
        raise bad(field, where, "not valid JSON (nested too deeply)") from None
    except ValueError as error:  # JSONDecodeError, or an integer of thousands of digits
        raise bad(field, where, f"not valid JSON ({_why(error)})") from None


def read_json(path: str | os.PathLike, field: str):
    """:func:`read_text` then :func:`parse_json`."""
    return parse_json(read_text(path, field), field, str(path))


def read_toml(path: str | os.PathLike, field: str) -> dict:
    """:func:`read_text` then TOML, or a one-line error naming ``field`` and the file: invalid,
    nested too deeply, an integer too long."""


    text = read_text(path, field)
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise bad(field, str(path), "not valid TOML (nested too deeply)") from None
    except ValueError as error:  # TOMLDecodeError, or an integer of thousands of digits
        raise bad(field, str(path), f"not valid TOML ({_why(error)})") from None
