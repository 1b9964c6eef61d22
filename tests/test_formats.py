"""One reader/writer of somite's file formats (somite.formats): every file written starts with its
format's header, and every reader refuses another format, an old version or a newer one in one
line; a path too long for the file system is a one-line error too."""

from __future__ import annotations

import numpy as np
import pytest

from somite.brain.genome import Genome
from somite.cli import main
from somite.errors import SomiteError
from somite.evolution.operators import initial_genome
from somite.formats import FORMATS, GENOME, MANIFEST_FILE, PARTITION
from somite.modules.library import module_from_dict, module_to_dict, provenance_of
from somite.modules.module import cut
from somite.sim.body import Body
from somite.sim.partition import Partition

VERSIONED = [f for f in FORMATS.values() if f.version is not None]


def message(action) -> str:
    with pytest.raises(SomiteError) as info:
        action()
    text = str(info.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize("fmt", FORMATS.values(), ids=list(FORMATS))
def test_every_format_reads_its_own_header(fmt):
    head = fmt.header()
    assert list(head) == (["format"] if fmt.version is None else ["format", "version"])
    assert fmt.check({**head, "more": 1}) == {**head, "more": 1} and fmt.matches(head)
    other = next(f for f in FORMATS.values() if f is not fmt)
    assert not fmt.matches(other.header()) and not fmt.matches([head])
    assert message(lambda: fmt.check(other.header())) == (
        f"format={other.name!r}: not a {fmt.what} file; expected {fmt.name!r}"
    )


@pytest.mark.parametrize("fmt", VERSIONED, ids=[f.name for f in VERSIONED])
def test_every_version_but_its_own_is_refused_in_one_line(fmt):
    head = fmt.header()
    newer = message(lambda: fmt.check({**head, "version": fmt.version + 1}))
    assert newer.startswith(
        f"version={fmt.version + 1}: written by a newer somite; this "
        f"somite reads {fmt.what} version {fmt.version} (upgrade somite)"
    )
    for old in (fmt.version - 1, True, "1", None, 1.0):
        assert message(lambda old=old: fmt.check({**head, "version": old})).startswith(
            f"version={old!r}: "
        )
    by_file = message(lambda: fmt.check({**head, "version": 0}, "input", "f.json"))
    assert by_file.startswith("input='f.json': version 0 ")


def test_the_readers_use_the_formats():
    body = Body.build("worm")
    genome = initial_genome(body, np.random.default_rng(0))
    partition = Partition.preset("worm-halves", "worm")
    module = cut(genome, partition).modules[0]
    written = {
        "somite-genome": genome.to_dict(),
        "somite-partition": partition.to_dict(),
        "somite-module": module_to_dict(module, provenance_of(module, genome, "AAABBB/AAABBB")),
    }
    read = {
        "somite-genome": Genome.from_dict,
        "somite-partition": lambda data: Partition.from_dict(data, "worm", "p.json"),
        "somite-module": lambda data: module_from_dict(data, "front"),
    }
    for name, data in written.items():
        fmt = FORMATS[name]
        assert {k: data[k] for k in fmt.header()} == fmt.header()
        read[name](data)
        newer = {**data, "version": fmt.version + 1}
        assert "written by a newer somite" in message(lambda f=read[name], d=newer: f(d))
    assert message(lambda: Genome.from_dict([])) == "genome='list': expected a JSON object"
    assert message(lambda: Partition.from_dict(GENOME.header(), None, "p.json")) == (
        "partition='p.json': not a partition file (format 'somite-genome'; expected "
        "'somite-partition')"
    )
    assert not PARTITION.matches(MANIFEST_FILE.header())


def test_old_error_messages_are_kept(tmp_path):
    data = initial_genome(Body.build("worm"), np.random.default_rng(0)).to_dict()
    assert message(lambda: Genome.from_dict({**data, "version": 0})) == (
        "version=0: unsupported; this somite reads genome version 1"
    )
    assert message(lambda: Genome.from_dict({**data, "format": "jgea"})) == (
        "format='jgea': not a genome file; expected 'somite-genome'"
    )


def test_a_path_too_long_for_the_file_system_is_one_line(tmp_path, capsys):
    long = str(tmp_path / ("a" * 300 + ".json"))
    assert message(lambda: Genome.load(long)).startswith("genome=")
    for command in (
        ["evaluate", long],
        ["module", "list", long],
        ["plot", long, "--out", str(tmp_path / "p.png")],
    ):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "File name too long" in err, err
