"""A campaign pack from elsewhere (issue 71): whatever it holds, an unpack is one line or a
campaign, in bounded memory and disk, and leaves nothing behind when refused or killed."""

from __future__ import annotations

import hashlib
import json
import lzma
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from somite.campaigns import directory as campaign_dir
from somite.campaigns.expansion import expand
from somite.campaigns.pack import MAGIC, _Writer, pack
from somite.campaigns.spec import parse
from somite.campaigns.unpack import unpack
from somite.cli import main
from somite.errors import SomiteError

SPEC = {"defaults": {"generations": 2, "population": 4},
        "experiments": {"rq1": {"kind": "evolve", "shapes": ["worm"], "seeds": [0]}}}


@pytest.fixture(scope="module")
def packed(tmp_path_factory) -> Path:
    """A pack of a campaign prepared but not run, with one extra file in its task's folder."""
    folder = tmp_path_factory.mktemp("packed")
    campaign = parse(SPEC, name="tiny", source="tiny.toml")
    root = folder / "c"
    campaign_dir.prepare(root, campaign_dir.document(campaign, expand(campaign)), resume=False)
    (root / "rq1" / "worm-s0").mkdir(parents=True)
    (root / "rq1" / "worm-s0" / "notes.txt").write_text("kept as it is\n")
    pack(root, folder / "c.pack")
    return folder / "c.pack"


def _open_pack(path: Path) -> tuple[dict, list[bytes]]:
    payload = lzma.decompress(path.read_bytes()[len(MAGIC):])
    (length,) = struct.unpack("<q", payload[:8])
    index = json.loads(payload[8:8 + length])
    blobs, at = [], 8 + length
    for entry in index["files"]:
        blobs.append(payload[at:at + entry["length"]])
        at += entry["length"]
    return index, blobs


def _write_pack(path: Path, index: dict, blobs: list[bytes], tail: bytes = b"") -> Path:
    head = json.dumps(index).encode()
    payload = struct.pack("<q", len(head)) + head + b"".join(blobs)
    path.write_bytes(MAGIC + lzma.compress(payload, format=lzma.FORMAT_XZ) + tail)
    return path


def _entry(path: str, encoding: str, stored: bytes, content: bytes) -> dict:
    return {"path": path, "encoding": encoding, "length": len(stored), "size": len(content),
            "sha256": hashlib.sha256(content).hexdigest()}


def _refused(capsys, tmp_path: Path, pack_path: Path, *more: str) -> str:
    capsys.readouterr()
    assert main(["campaign", "unpack", str(pack_path), "--out", str(tmp_path / "u"),
                 "--quiet", *more]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert not (tmp_path / "u").exists() and not list(tmp_path.glob(".u.unpack.*"))
    return err


def _crafted(packed: Path, tmp_path: Path, craft) -> Path:
    index, blobs = _open_pack(packed)
    craft(index, blobs)
    return _write_pack(tmp_path / "crafted.pack", index, blobs)


def _add(index, blobs, entry, stored):
    index["files"].append(entry)
    blobs.append(stored)


def _checkpoint_of(text: str) -> bytes:
    w = _Writer()
    w.ints(0)
    w.text(text)
    w.ints(0)
    return w.bytes()


def _short_log() -> bytes:
    w = _Writer()
    w.ints(2)  # two rows; the first column says both are full and holds one value
    w.ints(0)
    w.array([0, 0], "<u1")
    w.array([7], "<i8")
    return w.bytes()


def _bests_of(genomes: int) -> bytes:
    """A bests.jsonl entry of ``genomes`` lines each naming the index's first body."""
    w = _Writer()
    w.ints(genomes)
    w.text("")
    for generation in range(genomes):
        w.ints(0, generation)
        w.array([1.0], "<f8")
        w.ints(0)
        w.text("op")
        w.ints(0, 0, 0)
    return w.bytes()


CRAFTS = {
    "a NUL in a path": (lambda i, b: _add(i, b, _entry("rq1/a\0b", "raw", b"x", b"x"), b"x"),
                        "control character"),
    "a checkpoint that is a list": (
        lambda i, b: _add(i, b, _entry("rq1/checkpoint.json", "checkpoint",
                                       _checkpoint_of("[]"), b"[]"), _checkpoint_of("[]")),
        "does not come back"),
    "a short log column": (lambda i, b: _add(i, b, _entry("rq1/log.csv", "log", _short_log(),
                                                          b"x"), _short_log()),
                           "does not come back"),
    "a list for a genome's header": (
        lambda i, b: (i.update(bodies=["[1]\n{}"]),
                      _add(i, b, _entry("rq1/bests.jsonl", "bests", _bests_of(1), b"x" * 99),
                           _bests_of(1))),
        "does not come back"),
    "bodies that are a number": (lambda i, b: i.update(bodies=5), "bodies"),
    "campaign.json twice": (lambda i, b: _add(i, b, dict(i["files"][0]), b[0]), "listed twice"),
    "a file that is also a folder": (
        lambda i, b: (_add(i, b, _entry("rq1", "raw", b"x", b"x"), b"x")),
        "both a file and a folder"),
    "a file longer than its entry": (lambda i, b: b.append(b"more"), "after the last file"),
    "a raw file stored in fewer bytes": (
        lambda i, b: _add(i, b, {**_entry("rq1/x", "raw", b"x", b"x"), "size": 5}, b"x"),
        "stored as it is"),
    # 10,000 genomes of a 1 MB body would decode to 10 GB; each is charged as it is built.
    "genomes naming a long body": (
        lambda i, b: (i.update(bodies=['{"format":"somite-genome","version":1}\n"'
                                       + "x" * 2**20 + '"']),
                      _add(i, b, _entry("rq1/bests.jsonl", "bests", _bests_of(10_000),
                                        b"x" * 1000), _bests_of(10_000))),
        "grows past its size"),
}


@pytest.mark.parametrize("craft", list(CRAFTS))
def test_a_crafted_pack_is_one_line_and_writes_nothing(packed, tmp_path, capsys, craft):
    change, why = CRAFTS[craft]
    err = _refused(capsys, tmp_path, _crafted(packed, tmp_path, change))
    assert "damaged pack" in err and why in err and str(tmp_path / "crafted.pack") in err


@pytest.mark.parametrize("tail", [b"junk", lzma.compress(b"a second stream")])
def test_anything_after_the_stream_is_refused(packed, tmp_path, capsys, tail):
    crafted = tmp_path / "tail.pack"
    crafted.write_bytes(packed.read_bytes() + tail)
    assert "after its compressed stream" in _refused(capsys, tmp_path, crafted)


def test_a_pack_over_the_size_limit_is_refused_until_raised(packed, tmp_path, capsys):
    huge = 3 * 2**30  # declared, not stored: refused from the index, before reading it
    crafted = _crafted(packed, tmp_path, lambda i, b: _add(
        i, b, {**_entry("rq1/big", "raw", b"", b""), "length": huge, "size": huge}, b""))
    err = _refused(capsys, tmp_path, crafted)
    assert "3.00 GiB, over the limit of 2.00 GiB" in err and "--max-gib" in err
    # Raised, the pack is read: it ends before the file is whole.
    err = _refused(capsys, tmp_path, crafted, "--max-gib", "4")
    assert "ends before its last file" in err or "MB free" in err
    assert "max-gib=" in _refused(capsys, tmp_path, packed, "--max-gib", "0")


@pytest.mark.parametrize("special", ["/dev/zero", "fifo"])
def test_special_files_are_refused_unread(tmp_path, capsys, special):
    if special == "fifo":
        special = str(tmp_path / "fifo")
        os.mkfifo(special)  # opened without a writer: refused, not waited on
    assert "not a regular file" in _refused(capsys, tmp_path, Path(special))


def test_a_killed_unpacks_staging_folder_is_removed_by_the_next(packed, tmp_path):
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead = tmp_path / f".u.unpack.{int(gone.stdout)}.0123abcd"
    live = tmp_path / f".u.unpack.{os.getpid()}.0123abcd"
    for staging in (dead, live):
        (staging / "rq1").mkdir(parents=True)
        (staging / "rq1" / "big").write_bytes(b"x" * 1000)
    unpack(packed, tmp_path / "u")
    assert (tmp_path / "u" / "rq1" / "worm-s0" / "notes.txt").read_text() == "kept as it is\n"
    assert not dead.exists() and live.exists()  # a live unpack's is its own


def test_a_read_only_campaign_is_packed_without_its_lock(packed, tmp_path, monkeypatch):
    root = tmp_path / "c"
    unpack(packed, root)
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False if Path(p) == root
                        else real(p, mode, **k))
    pack(root, tmp_path / "again.pack")  # the lock would be written in the campaign folder
    assert not list(root.rglob("*.lock")) and not list(root.rglob(".lock"))
    assert _open_pack(tmp_path / "again.pack")[1] == _open_pack(packed)[1]


def test_a_campaign_lock_refusal_names_the_campaign(packed, tmp_path):
    from somite.experiments.lock import RunLock

    root = tmp_path / "c"
    unpack(packed, root)
    with RunLock(root), pytest.raises(SomiteError, match=r"^campaign="):
        pack(root, tmp_path / "again.pack")


def test_an_unpack_creates_the_folders_above_out(packed, tmp_path):
    unpack(packed, tmp_path / "a" / "b" / "u")
    assert (tmp_path / "a" / "b" / "u" / "campaign.json").is_file()
