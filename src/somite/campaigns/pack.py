"""``somite campaign pack`` and ``unpack``: a campaign's whole resumable state in one file.

A pack holds every file of a campaign directory (``campaign.json``, each task's folder) but its
locks and the temporary files of interrupted writes, so that ``campaign run --resume`` on the
unpacked folder goes on as it would have in the packed one: every file is unpacked byte for
byte as it was, but one kind of line. What it is made of:

- a magic line, then one xz (LZMA) stream of: the length of the index (8 bytes), the index
  (JSON: format, version, campaign name, thinning, the body and node-kind tables, and per file
  its path, encoding, byte count and the sha256 of the bytes unpacked), and each file's data;
- genomes (a checkpoint's population, a run's bests) as binary arrays (node ids, positions,
  kinds, slots; edge ends, weights, biases), ``log.csv`` as binary columns (float64, int64, or
  text where a cell would not come back as written), the rest as it is. Each encoded file is
  decoded again while packing and kept as text where it does not come back byte for byte, so
  an encoding can make a pack bigger but never change a file;
- thinning: an evolve run's ``bests.jsonl`` keeps its best of every :data:`EVERY` th
  generation and of the last :data:`LAST`; each other line becomes a *thinned* line that
  stands for it (:data:`somite.experiments.history.THINNED`: its generation and the short
  digest of the line its checkpoint seals), so that resuming, cutting back and sealing
  checkpoints go on exactly as before. The report reads ``log.csv`` and ``best.json``, not
  those genomes. A re-optimisation's bests are kept whole (its transfer curve reads them all).

Packing holds the campaign's lock and refuses a campaign with a task running (a campaign
folder it cannot write, read-only, is packed without the lock: nothing of it can run there);
unpacking (:mod:`.unpack`) writes into a hidden folder beside ``--out`` and renames it into
place once every file is written and checked, so a failure leaves no half campaign.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import lzma
import math
import os
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import formats
from .._io import (
    CHECK_PREFIX,
    TEMPORARY,
    check_output_file,
    write_atomic,
)
from ..errors import bad
from ..experiments.history import THINNED, line_digest, thinned_line
from ..experiments.lock import LOCK_NAME, RunLock
from ..experiments.logfile import LOG_COLUMNS
from . import directory as campaign_dir

MAGIC = b"somite campaign pack\n"
"""The first bytes of a pack (then the xz stream)."""
EVERY = 10
"""An evolve run's bests are kept every EVERY generations..."""
LAST = 10
"""...and for its LAST generations."""
THINNED_KINDS = ("evolve",)
"""The task kinds whose bests are thinned."""
MAX_ENCODED = 64 * 2**20
"""The largest file whose genomes or log a pack encodes (a larger one goes as it is):
unpacking decodes such a file in memory. The paper's largest (a bests.jsonl) is 2.4 MB."""

Say = Callable[[str], None]


# -- binary pieces -----------------------------------------------------------------------------

class _Writer:
    def __init__(self) -> None:
        self.out = io.BytesIO()

    def ints(self, *values: int) -> None:
        self.out.write(struct.pack(f"<{len(values)}q", *values))

    def array(self, values, dtype: str) -> None:
        self.out.write(np.asarray(values, dtype=dtype).tobytes())

    def text(self, value: str) -> None:
        data = value.encode("utf-8")
        self.ints(len(data))
        self.out.write(data)

    def bytes(self) -> bytes:
        return self.out.getvalue()


class _Reader:
    def __init__(self, data: bytes) -> None:
        self.data, self.at = data, 0

    def take(self, count: int) -> bytes:
        if count < 0 or self.at + count > len(self.data):
            raise ValueError("truncated")
        piece = self.data[self.at:self.at + count]
        self.at += count
        return piece

    def ints(self, count: int = 1) -> tuple[int, ...]:
        return struct.unpack(f"<{count}q", self.take(8 * count))

    def array(self, count: int, dtype: str) -> np.ndarray:
        return np.frombuffer(self.take(count * np.dtype(dtype).itemsize), dtype=dtype)

    def text(self) -> str:
        return self.take(self.ints()[0]).decode("utf-8")


@dataclass
class _Tables:
    """What genomes share: their bodies and node kinds, each stored once a pack."""

    bodies: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    charge: Callable[[int], None] | None = None
    """Told the bytes of each genome's body and node kinds before it is built (unpacking: a
    genome of a few bytes may name a long body, so decoding is bounded as it goes)."""

    def code(self, table: list[str], value: str) -> int:
        if value not in table:
            table.append(value)
        return table.index(value)


_GENOME_KEYS = ["format", "version", "body", "nodes", "edges"]
_INT64 = 2**63


def _is_int(value) -> bool:
    return type(value) is int and -_INT64 <= value < _INT64


def _put_genome(w: _Writer, genome, tables: _Tables) -> bool:
    """A genome's compact JSON (parsed) as arrays; False (nothing written) when it is not of
    the layout the arrays hold."""
    if not isinstance(genome, dict) or list(genome) != _GENOME_KEYS:
        return False
    nodes, edges = genome["nodes"], genome["edges"]
    if not (isinstance(nodes, list) and isinstance(edges, list)):
        return False
    for n in nodes:
        if not (isinstance(n, list) and len(n) == 5 and all(map(_is_int, n[:3]))
                and isinstance(n[3], str) and (n[4] is None or (_is_int(n[4]) and n[4] >= 0))):
            return False
    for e in edges:
        if not (isinstance(e, list) and len(e) == 4 and _is_int(e[0]) and _is_int(e[1])
                and type(e[2]) is float and type(e[3]) is float):
            return False
    head = json.dumps({k: genome[k] for k in ("format", "version")}, separators=(",", ":"))
    body = json.dumps(genome["body"], separators=(",", ":"))
    w.ints(tables.code(tables.bodies, head + "\n" + body), len(nodes), len(edges))
    columns = list(zip(*nodes)) if nodes else [[]] * 5
    w.array(columns[0], "<i8")
    w.array(columns[1], "<i8")
    w.array(columns[2], "<i8")
    w.array([tables.code(tables.kinds, k) for k in columns[3]], "<u2")
    w.array([-1 if s is None else s for s in columns[4]], "<i8")
    ends = list(zip(*edges)) if edges else [[]] * 4
    w.array(ends[0], "<i8")
    w.array(ends[1], "<i8")
    w.array(ends[2], "<f8")
    w.array(ends[3], "<f8")
    return True


def _get_genome(r: _Reader, tables: _Tables) -> dict:
    body_code, n, m = r.ints(3)
    head, body = tables.bodies[body_code].split("\n", 1)
    ids, xs, ys = (r.array(n, "<i8").tolist() for _ in range(3))
    kinds = [tables.kinds[k] for k in r.array(n, "<u2").tolist()]
    if tables.charge is not None:
        tables.charge(len(head) + len(body) + sum(map(len, kinds)))
    slots = [None if s < 0 else s for s in r.array(n, "<i8").tolist()]
    src, dst = r.array(m, "<i8").tolist(), r.array(m, "<i8").tolist()
    weight, bias = r.array(m, "<f8").tolist(), r.array(m, "<f8").tolist()
    return {**json.loads(head), "body": json.loads(body),
            "nodes": [list(row) for row in zip(ids, xs, ys, kinds, slots)],
            "edges": [list(row) for row in zip(src, dst, weight, bias)]}


def _compact(data) -> str:
    return json.dumps(data, separators=(",", ":"))


# -- the encodings of a file: each returns its data, or None (then the file goes as it is) ------

def _lines(text: str) -> tuple[list[str], str]:
    """Complete lines and the torn rest after the last newline."""
    lines = text.split("\n")
    return lines[:-1], lines[-1]


def _encode_bests(text: str, tables: _Tables, thin: bool) -> bytes:
    lines, rest = _lines(text)
    last = len(lines)
    w = _Writer()
    w.ints(len(lines))
    w.text(rest)
    for index, line in enumerate(lines):
        thinned = THINNED.fullmatch(line)
        if thinned:
            w.ints(1, int(thinned[1]))
            w.text(thinned[2])
            continue
        if thin and not (index % EVERY == 0 or index >= last - LAST):
            generation = _generation_of(line)
            if generation is not None:
                w.ints(1, generation)
                w.text(line_digest("bests", line))
                continue
        if not _put_best(w, line, tables):
            w.ints(2)
            w.text(line)
    return w.bytes()


def _generation_of(line: str) -> int | None:
    try:
        entry = json.loads(line)
    except ValueError:
        return None
    generation = entry.get("generation") if isinstance(entry, dict) else None
    return generation if _is_int(generation) and generation >= 0 else None


def _put_best(w: _Writer, line: str, tables: _Tables) -> bool:
    """A best's line as its generation, velocity, operator and genome arrays, where it comes
    back as written."""
    try:
        entry = json.loads(line)
    except ValueError:
        return False
    if not isinstance(entry, dict) or list(entry) != ["generation", "velocity", "operator",
                                                      "genome"]:
        return False
    velocity, operator = entry["velocity"], entry["operator"]
    if not (_is_int(entry["generation"]) and (velocity is None or type(velocity) is float)
            and isinstance(operator, str)):
        return False
    trial = _Writer()
    trial.ints(0, entry["generation"])
    trial.array([math.nan if velocity is None else velocity], "<f8")
    trial.ints(velocity is None)
    trial.text(operator)
    if not _put_genome(trial, entry["genome"], tables):
        return False
    data = trial.bytes()
    reader = _Reader(data)
    reader.ints()
    if _get_best(reader, tables) != line:
        return False
    w.out.write(data)
    return True


def _get_best(r: _Reader, tables: _Tables) -> str:
    generation = r.ints()[0]
    velocity = float(r.array(1, "<f8")[0])
    null = r.ints()[0]
    operator = r.text()
    genome = _get_genome(r, tables)
    return _compact({"generation": generation, "velocity": None if null else velocity,
                     "operator": operator, "genome": genome})


def _decode_bests(data: bytes, tables: _Tables) -> str:
    r = _Reader(data)
    count = r.ints()[0]
    rest = r.text()
    out = []
    for _ in range(count):
        how = r.ints()[0]
        if how == 0:
            out.append(_get_best(r, tables))
        elif how == 1:
            generation = r.ints()[0]
            out.append(thinned_line(generation, r.text()))
        else:
            out.append(r.text())
    return "".join(line + "\n" for line in out) + rest


def _encode_log(text: str) -> bytes | None:
    """``log.csv`` as columns: float64 where every cell is a float's repr (or empty), int64
    where every cell is an integer's str, else text."""
    lines, rest = _lines(text)
    if rest or not lines or lines[0] != ",".join(LOG_COLUMNS):
        return None
    rows = [line.split(",") for line in lines[1:]]
    if any(len(row) != len(LOG_COLUMNS) for row in rows):
        return None
    w = _Writer()
    w.ints(len(rows))
    for cells in zip(*rows) if rows else []:
        empty = [c == "" for c in cells]
        full = [c for c in cells if c]
        how = 2
        if all(_int_text(c) for c in full):
            how, values, dtype = 0, [int(c) for c in full], "<i8"
        elif all(_float_text(c) for c in full):
            how, values, dtype = 1, [float(c) for c in full], "<f8"
        w.ints(how)
        w.array(empty, "<u1")
        if how == 2:
            w.text("\n".join(full))
        else:
            w.array(values, dtype)
    return w.bytes()


def _int_text(cell: str) -> bool:
    try:
        return str(int(cell)) == cell and _is_int(int(cell))
    except ValueError:
        return False


def _float_text(cell: str) -> bool:
    try:
        return repr(float(cell)) == cell
    except ValueError:
        return False


def _decode_log(data: bytes) -> str:
    r = _Reader(data)
    count = r.ints()[0]
    columns = []
    for _ in LOG_COLUMNS if count else []:
        how = r.ints()[0]
        empty = r.array(count, "<u1").astype(bool)
        full = int(count - empty.sum())
        if how == 2:
            values = r.text().split("\n") if full else []
        elif how == 0:
            values = [str(v) for v in r.array(full, "<i8").tolist()]
        else:
            values = [repr(v) for v in r.array(full, "<f8").tolist()]
        found = iter(values)
        columns.append(["" if e else next(found) for e in empty])
    lines = [",".join(LOG_COLUMNS)] + [",".join(row) for row in zip(*columns)]
    return "".join(line + "\n" for line in lines)


def _encode_checkpoint(text: str, tables: _Tables) -> bytes | None:
    """A checkpoint: its population as genome arrays, its sealed history as 4-byte digests,
    the rest as JSON."""
    try:
        data = json.loads(text)
    except ValueError:
        return None
    if not isinstance(data, dict) or not isinstance(data.get("population"), list):
        return None
    history = data.get("history")
    digests = {}
    if isinstance(history, dict):
        for name in ("log", "bests"):
            found = history.get(name)
            if not (isinstance(found, list) and all(
                isinstance(d, str) and len(d) == 8 and all(c in "0123456789abcdef" for c in d)
                for d in found
            )):
                return None
            digests[name] = found
    w = _Writer()
    w.ints(len(data["population"]))
    for genome in data["population"]:
        if not _put_genome(w, genome, tables):
            return None
    rest = {k: (None if k in ("population", "history") else v) for k, v in data.items()}
    w.text(_compact(rest))
    w.ints(len(digests))
    for name, found in digests.items():
        w.text(name)
        w.ints(len(found))
        w.out.write(bytes.fromhex("".join(found)))
    return w.bytes()


def _decode_checkpoint(data: bytes, tables: _Tables) -> str:
    r = _Reader(data)
    population = [_get_genome(r, tables) for _ in range(r.ints()[0])]
    out = json.loads(r.text())
    out["population"] = population
    history = {}
    for _ in range(r.ints()[0]):
        name = r.text()
        count = r.ints()[0]
        raw = r.take(4 * count).hex()
        history[name] = [raw[i:i + 8] for i in range(0, len(raw), 8)]
    if history:
        out["history"] = history
    return _compact(out)


# -- pack ---------------------------------------------------------------------------------------

@dataclass
class Packed:
    """What :func:`pack` wrote: ``files`` and their ``size`` in bytes, the pack's ``bytes``,
    and bests kept whole and thinned."""

    files: int = 0
    size: int = 0
    bytes: int = 0
    bests_kept: int = 0
    bests_thinned: int = 0


def _skipped(name: str) -> bool:
    """A lock, or a temporary file of an interrupted write or an output folder's check."""
    return name == LOCK_NAME or bool(TEMPORARY.fullmatch(name)) or name.startswith(CHECK_PREFIX)


def _files(root: Path) -> list[Path]:
    """Every file of the campaign folder to pack, in a fixed order; a link or anything but a
    file or folder is a one-line error."""
    found = []
    for folder, dirs, names in os.walk(root):
        dirs.sort()
        for name in sorted(dirs + names):
            path = Path(folder) / name
            if path.is_symlink():
                raise bad("campaign", str(path), "is a symbolic link; a pack holds files only "
                          "(copy what it points to into the campaign, or move it away)")
            if name in names and not _skipped(name):
                if not path.is_file():
                    raise bad("campaign", str(path), "is not a regular file")
                found.append(path)
    return found


def _encode(path: Path, data: bytes, tables: _Tables, thin: bool) -> tuple[str, bytes, bytes]:
    """(encoding, stored data, the bytes unpacking gives) of one file."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return "raw", data, data
    if len(data) > MAX_ENCODED:
        return "raw", data, data
    name = path.name
    attempt = None
    if name == "bests.jsonl":
        attempt = ("bests", _encode_bests(text, tables, thin), _decode_bests)
    elif name == "log.csv":
        attempt = ("log", _encode_log(text), lambda d, t: _decode_log(d))
    elif name == "checkpoint.json":
        attempt = ("checkpoint", _encode_checkpoint(text, tables), _decode_checkpoint)
    if attempt is None or attempt[1] is None:
        return "raw", data, data
    encoding, stored, decode = attempt
    try:
        back = decode(stored, tables).encode("utf-8")
    except (ValueError, KeyError, IndexError, struct.error):  # pragma: no cover - a bug
        back = None
    # Only thinning changes a file (its thinned lines); every line kept was checked to come
    # back as written.
    if back is None or len(stored) > MAX_ENCODED or (
            back != data and not (encoding == "bests" and thin)):
        return "raw", data, data
    return encoding, stored, back


def _busy(root: Path, doc: dict) -> str | None:
    """A task of the campaign whose run is going on (a live lock in its folder), or None."""
    for task in doc["tasks"]:
        if campaign_dir.state(root, task)["state"] == "running":
            return task["id"]
    return None


def pack(directory: str | Path, out: str | Path, say: Say | None = None) -> Packed:
    """Write the campaign in ``directory`` into the pack ``out`` (see the module docstring)."""
    say = say or (lambda text: None)
    root = Path(directory)
    doc = campaign_dir.read(root)
    target = check_output_file(out)
    if root.resolve() in target.resolve().parents:
        raise bad("out", str(out), f"is inside the campaign folder {directory}; write the pack "
                  "outside it")
    thinned_tasks = {t["path"] for t in doc["tasks"] if t["kind"] in THINNED_KINDS}
    # A folder this process cannot write (read-only) cannot take the lock, and no task of it
    # can be run from here: it is packed as it is.
    writable = os.access(root, os.W_OK)
    with RunLock(root, field="campaign") if writable else contextlib.nullcontext():
        task = _busy(root, doc)
        if task is not None:
            raise bad("campaign", str(directory), f"its task {task} is running; pack it when "
                      "the campaign is stopped")
        files = _files(root)
        tables = _Tables()
        entries, blobs, result = [], [], Packed()
        order = [t["path"] for t in doc["tasks"]]
        shown = None
        for path in files:
            relative = path.relative_to(root).as_posix()
            task_path = relative.rsplit("/", 1)[0]
            if task_path in order and task_path != shown:  # a task's files come together
                shown = task_path
                say(f"reading {task_path} ({order.index(task_path) + 1} of {len(order)} "
                    "tasks)")
            data = path.read_bytes()
            thin = task_path in thinned_tasks
            encoding, stored, back = _encode(path, data, tables, thin)
            if encoding == "bests":
                lines = back.count(b"\n")
                thinned = sum(1 for line in back.decode("utf-8").split("\n")
                              if THINNED.fullmatch(line))
                result.bests_kept += lines - thinned
                result.bests_thinned += thinned
            entries.append({"path": relative, "encoding": encoding, "length": len(stored),
                            "size": len(back), "sha256": hashlib.sha256(back).hexdigest()})
            blobs.append(stored)
            result.files += 1
            result.size += len(data)
        say(f"read {result.files} files ({result.size / 1e6:.1f} MB) of {len(doc['tasks'])} "
            "tasks; compressing")
        index = {**formats.CAMPAIGN_PACK.header(), "campaign": doc.get("name"),
                 "thinning": {"every": EVERY, "last": LAST, "kinds": list(THINNED_KINDS)},
                 "bodies": tables.bodies, "kinds": tables.kinds, "files": entries}
        head = json.dumps(index, separators=(",", ":")).encode("utf-8")
        payload = struct.pack("<q", len(head)) + head + b"".join(blobs)
        packed = MAGIC + lzma.compress(payload, format=lzma.FORMAT_XZ,
                                       preset=9 | lzma.PRESET_EXTREME)
        write_atomic(target, packed)
    result.bytes = len(packed)
    return result


__all__ = ["EVERY", "LAST", "MAGIC", "MAX_ENCODED", "Packed", "pack"]
