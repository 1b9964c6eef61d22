"""``somite campaign unpack``: a pack (:mod:`.pack`) back into a campaign folder, in bounded
memory and disk whatever the pack holds.

A pack comes from elsewhere (a colleague, a cluster), so nothing in it is trusted:

- the file must be a regular file (not ``/dev/zero``, a FIFO or a device), read in pieces of
  :data:`CHUNK` bytes and decompressed as it is read (the xz decoder itself at most
  :data:`DECODER_MEMORY`), never whole;
- its index is checked as a whole before anything is written: at most :data:`MAX_INDEX`
  bytes and :data:`MAX_FILES` files, each path relative, inside the campaign, without control
  characters, listed once and not also a folder of another; its files at most
  :data:`DEFAULT_MAX_BYTES` in all (``max_bytes``, ``--max-gib`` raises it) and not more than
  the free space of the disk; a genome or log entry (decoded in memory) at most
  :data:`MAX_ENCODED` bytes, the others streamed to disk;
- while streaming, each file must be as long as its index says, decode to no more than its
  size (genomes are charged as they are built, so a small entry cannot grow into gigabytes)
  and have its sha256; the stream must end with the last file, and the file with the stream;
- any of that amiss is one line, ``pack=...: damaged pack (...)``, and nothing is left.

The files are written into a hidden staging folder beside ``--out`` and renamed into place at
the end; an unpack killed on the way leaves its staging folder, which the next unpack into the
same ``--out`` removes (its process being gone).
"""

from __future__ import annotations

import glob
import hashlib
import json
import lzma
import os
import re
import shutil
import stat
import struct
import uuid
from pathlib import Path

from .. import formats
from .._io import check_output_folder, reason
from ..errors import SomiteError, bad
from . import directory as campaign_dir
from .layout import CAMPAIGN
from .pack import MAGIC, MAX_ENCODED, Say, _decode_bests, _decode_checkpoint, _decode_log, _Tables

CHUNK = 1 << 20
"""Bytes read from the pack, and decompressed, at a time."""
DECODER_MEMORY = 256 * 2**20
"""The most memory the xz decoder may use (a pack's stream needs about 65 MiB; a crafted
header could ask for gigabytes)."""
MAX_INDEX = 64 * 2**20
"""The most bytes of a pack's index (the paper's campaign: under 100 kB)."""
MAX_FILES = 100_000
"""The most files of a pack (the paper's campaign: a few hundred)."""
DEFAULT_MAX_BYTES = 2 * 2**30
"""The most bytes an unpack writes, unless raised (``--max-gib``): 60 times the paper's
campaign (32 MB)."""
MAX_PATH = 1024
"""The most characters of a file's path in a pack (each part at most 255 bytes)."""
ENCODINGS = ("raw", "bests", "log", "checkpoint")
_SHA256 = re.compile(r"[0-9a-f]{64}")
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
# Every error a decoder can raise on crafted data (a list where an object is, a column short
# of cells, a code past a table's end, nesting too deep for json).
_DECODE_ERRORS = (ValueError, KeyError, IndexError, TypeError, AttributeError, StopIteration,
                  RecursionError, OverflowError, struct.error)


class _Damaged(Exception):
    """What is wrong with a pack, in a few words (made a one-line error by :func:`unpack`)."""


class _Stream:
    """The pack's xz stream, decompressed as it is read: at most :data:`CHUNK` bytes of
    either at once, beyond what a caller asks for."""

    def __init__(self, handle) -> None:
        self.handle = handle
        self.decoder = lzma.LZMADecompressor(format=lzma.FORMAT_XZ, memlimit=DECODER_MEMORY)
        self.buffer = bytearray()

    def _more(self) -> None:
        if self.decoder.eof:
            raise _Damaged("it ends before its last file")
        data = b""
        if self.decoder.needs_input:
            try:
                data = self.handle.read(CHUNK)
            except OSError as error:  # not the output's fault: the pack cannot be read
                raise _Damaged(f"cannot read it: {reason(error)}") from None
            if not data:
                raise _Damaged("it ends before its last file")
        try:
            self.buffer += self.decoder.decompress(data, max_length=CHUNK)
        except lzma.LZMAError as error:
            raise _Damaged(str(error)) from None

    def read(self, count: int) -> bytes:
        while len(self.buffer) < count:
            self._more()
        piece = bytes(self.buffer[:count])
        del self.buffer[:count]
        return piece

    def pieces(self, count: int):
        """``count`` bytes in pieces of at most :data:`CHUNK`."""
        while count > 0:
            piece = self.read(min(count, CHUNK))
            count -= len(piece)
            yield piece

    def check_end(self) -> None:
        """Nothing after the last file: not in the stream, not after it in the file."""
        if self.buffer:
            raise _Damaged("data after the last file")
        while not self.decoder.eof:
            self._more()
            if self.buffer:
                raise _Damaged("data after the last file")
        if self.decoder.unused_data or self.handle.read(1):
            raise _Damaged("data after its compressed stream")


def _open(path: str | Path):
    """The pack, opened for reading: a regular file, or a one-line error (a FIFO is opened
    without waiting for a writer, then refused)."""
    where = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as error:
        raise bad("pack", where, f"cannot read it ({reason(error)})") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise bad("pack", where, "is not a regular file (a pack is a file `somite campaign "
                  "pack` wrote)")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def _read_index(stream: _Stream) -> dict:
    (length,) = struct.unpack("<q", stream.read(8))
    if not 0 < length <= MAX_INDEX:
        raise _Damaged(f"an index of {length} bytes; at most {MAX_INDEX}")
    try:
        index = json.loads(stream.read(length).decode("utf-8"))
    except (ValueError, RecursionError) as error:
        raise _Damaged(f"its index is not JSON: {str(error)[:80]}") from None
    if not isinstance(index, dict):
        raise _Damaged("its index is not a JSON object")
    return index


def _path_problem(path: str) -> str | None:
    parts = path.split("/")
    if path.startswith("/") or "\\" in path or any(p in ("", ".", "..") for p in parts):
        return "a file outside the campaign"
    if _CONTROL.search(path):
        return "a control character in a file's path"
    if len(path) > MAX_PATH or any(len(p.encode("utf-8", "replace")) > 255 for p in parts):
        return "a file's path too long"
    return None


def _check_entry(entry) -> dict:
    if not (isinstance(entry, dict) and isinstance(entry.get("path"), str)
            and entry.get("encoding") in ENCODINGS
            and all(type(entry.get(k)) is int and entry[k] >= 0 for k in ("length", "size"))
            and isinstance(entry.get("sha256"), str) and _SHA256.fullmatch(entry["sha256"])):
        raise _Damaged(f"file entry {str(entry)[:60]}")
    problem = _path_problem(entry["path"])
    if problem:
        raise _Damaged(f"{problem}: {entry['path']!r}")
    if entry["encoding"] == "raw" and entry["length"] != entry["size"]:
        raise _Damaged(f"{entry['path']} is stored as it is, yet in {entry['length']} bytes "
                       f"for {entry['size']}")
    if entry["encoding"] != "raw" and max(entry["length"], entry["size"]) > MAX_ENCODED:
        raise _Damaged(f"{entry['path']} is over {MAX_ENCODED} bytes, more than a pack "
                       "encodes")
    return entry


def _check_index(index: dict, max_bytes: int) -> tuple[list[dict], _Tables]:
    """The index's files, each checked, and its tables; nothing written yet."""
    entries, bodies, kinds = index.get("files"), index.get("bodies", []), index.get("kinds", [])
    if not isinstance(entries, list) or len(entries) > MAX_FILES:
        raise _Damaged(f"its index lists no files or more than {MAX_FILES}")
    for name, table in (("bodies", bodies), ("kinds", kinds)):
        if not (isinstance(table, list) and all(isinstance(t, str) for t in table)):
            raise _Damaged(f"its {name} are not a list of texts")
    entries = [_check_entry(e) for e in entries]
    paths = [e["path"] for e in entries]
    if len(set(paths)) != len(paths):
        twice = next(p for p in paths if paths.count(p) > 1)
        raise _Damaged(f"{twice} is listed twice")
    folders = {p.rsplit("/", i)[0] for p in paths for i in range(1, p.count("/") + 1)}
    both = folders & set(paths)
    if both:
        raise _Damaged(f"{min(both)} is both a file and a folder")
    if CAMPAIGN not in paths:
        raise _Damaged("no campaign.json")
    # Stored bytes too: each is decompressed and read, even where its file is small.
    total = max(sum(e["size"] for e in entries), sum(e["length"] for e in entries))
    if total > max_bytes:
        raise _Exceeds(total)
    return entries, _Tables(list(bodies), list(kinds))


class _Exceeds(Exception):
    """The pack's files are more bytes than the unpack may write."""


def _charge(limit: int):
    """A counter of the bytes a decoder builds, past ``limit`` a damaged pack: a genome is
    charged its body and node kinds (from the index's tables) before it is built."""
    spent = [0]

    def charge(count: int) -> None:
        spent[0] += count
        if spent[0] > limit:
            raise _Damaged("a file grows past its size as it is decoded")
    return charge


def _decoded(entry: dict, stored: bytes, tables: _Tables) -> bytes:
    tables.charge = _charge(entry["size"])
    try:
        if entry["encoding"] == "log":
            return _decode_log(stored).encode("utf-8")
        if entry["encoding"] == "bests":
            return _decode_bests(stored, tables).encode("utf-8")
        return _decode_checkpoint(stored, tables).encode("utf-8")
    except _DECODE_ERRORS:
        raise _Damaged(f"{entry['path']} does not come back as packed") from None


def _write(stream: _Stream, entry: dict, file: Path, tables: _Tables) -> None:
    """One file from the stream into ``file``, checked against its entry."""
    digest, size = hashlib.sha256(), 0
    with open(file, "xb") as out:
        if entry["encoding"] == "raw":
            for piece in stream.pieces(entry["length"]):
                digest.update(piece)
                out.write(piece)
            size = entry["length"]
        else:
            content = _decoded(entry, stream.read(entry["length"]), tables)
            digest.update(content)
            size = len(content)
            if size == entry["size"]:
                out.write(content)
    if size != entry["size"] or digest.hexdigest() != entry["sha256"]:
        raise _Damaged(f"{entry['path']} does not come back as packed")


_STAGING = re.compile(r"\.(?P<name>.+)\.unpack\.(?P<pid>\d+)\.[0-9a-f]{8}")


def _staging(target: Path) -> Path:
    return target.parent / f".{target.name}.unpack.{os.getpid()}.{uuid.uuid4().hex[:8]}"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):  # another user's process; a pid past the range
        return pid < 2**31
    return True


def remove_stale_staging(target: Path) -> None:
    """The staging folders of earlier unpacks into ``target`` whose process is gone (killed):
    a live unpack's is left alone."""
    for path in target.parent.glob(f".{glob.escape(target.name)}.unpack.*"):
        found = _STAGING.fullmatch(path.name)
        if found and found["name"] == target.name and path.is_dir() and not path.is_symlink() \
                and not _alive(int(found["pid"])):
            shutil.rmtree(path, ignore_errors=True)


def _check_campaign(staging: Path, target: Path) -> None:
    """The pack's campaign.json checked as a whole, as a campaign's; a refusal names the
    folder it was to become, not the staging folder that goes away."""
    try:
        campaign_dir.read(staging)
    except SomiteError as error:
        raise _Damaged(str(error).replace(str(staging), str(target))) from None


def _check_room(target: Path, total: int) -> None:
    existing = next(p for p in (target, *target.parents) if p.exists())
    free = shutil.disk_usage(existing).free
    if total > free:
        raise bad("out", str(target), f"the pack unpacks to {total / 1e6:.1f} MB and its disk "
                  f"has {free / 1e6:.1f} MB free")


def unpack(pack_path: str | Path, out: str | Path, say: Say | None = None,
           max_bytes: int = DEFAULT_MAX_BYTES) -> dict:
    """Restore the pack ``pack_path`` into the new (or empty) folder ``out`` (see the module
    docstring), writing at most ``max_bytes``; returns its index."""
    say = say or (lambda text: None)
    where = str(pack_path)
    target = check_output_folder(out)
    if target.exists() and any(target.iterdir()):
        raise bad("out", str(out), "is not empty; unpack into a new or empty folder")
    remove_stale_staging(target)
    staging = _staging(target)
    with _open(pack_path) as handle:
        try:
            if handle.read(len(MAGIC)) != MAGIC:
                raise bad("pack", where, "not a somite campaign pack (`somite campaign pack` "
                          "writes them)")
            stream = _Stream(handle)
            index = _read_index(stream)
            formats.CAMPAIGN_PACK.check(index, "pack", where)
            entries, tables = _check_index(index, max_bytes)
            total = sum(e["size"] for e in entries)
            _check_room(target, total)
            say(f"unpacking {len(entries)} files ({total / 1e6:.1f} MB)")
            staging.mkdir(parents=True)
            shown = ""
            for number, entry in enumerate(entries, 1):
                file = staging / entry["path"]
                file.parent.mkdir(parents=True, exist_ok=True)
                _write(stream, entry, file, tables)
                folder = entry["path"].rpartition("/")[0]
                if folder and folder != shown:
                    shown = folder
                    say(f"unpacking {folder} (file {number} of {len(entries)})")
            stream.check_end()
            _check_campaign(staging, target)
            if target.exists():
                target.rmdir()
            os.rename(staging, target)
        except _Damaged as error:
            raise bad("pack", where, f"damaged pack ({error})") from None
        except _Exceeds as error:
            raise bad("pack", where, f"unpacks to {error.args[0] / 2**30:.2f} GiB, over the "
                      f"limit of {max_bytes / 2**30:.2f} GiB (raise it with --max-gib, or "
                      "max_bytes= in Python)") from None
        except OSError as error:
            raise bad("out", str(out), f"cannot write it ({reason(error)})") from None
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)
    return index


__all__ = ["CHUNK", "DEFAULT_MAX_BYTES", "MAX_FILES", "MAX_INDEX", "remove_stale_staging",
           "unpack"]
