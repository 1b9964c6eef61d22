"""The README teaches what works: its tutorial runs as a script from an empty folder, every
``somite`` command it shows parses, and its Python block runs."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from somite.cli import build_parser, main

README = Path(__file__).resolve().parents[1] / "README.md"


def _block(marker: str, language: str) -> str:
    """The fenced block of ``language`` right after the HTML comment ``marker``."""
    text = README.read_text()
    start = text.index(f"<!-- {marker} -->")
    opening = text.index(f"```{language}\n", start) + len(language) + 4
    return text[opening:text.index("```", opening)]


def _commands(block: str) -> list[str]:
    """Shell lines of ``block`` without comments, continuation lines joined."""
    lines, current = [], ""
    for raw in block.splitlines():
        line = raw.split(" #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        current += line
        if current.strip():
            lines.append(current.strip())
        current = ""
    return lines


def _every_somite_command() -> list[list[str]]:
    text = README.read_text()
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in _commands(block):
            for part in line.split("&&"):
                words = shlex.split(part)
                if words and words[0] == "somite":
                    commands.append(words[1:])
    return commands


def test_the_readme_shows_commands_of_every_kind():
    used = {argv[0] for argv in _every_somite_command()}
    assert used >= {"simulate", "evolve", "evaluate", "show", "gait", "draw", "plot", "reassemble",
                    "reoptimize", "discover", "module", "assemble", "campaign", "report"}


@pytest.mark.parametrize("argv", _every_somite_command(), ids=" ".join)
def test_every_readme_command_parses(argv):
    build_parser().parse_args(argv)  # an unknown option or a bad choice exits with 2


def test_the_tutorial_runs_from_an_empty_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    commands = _commands(_block("tutorial", "sh"))
    assert commands[0] == "mkdir tour && cd tour"
    (tmp_path / "tour").mkdir()
    monkeypatch.chdir(tmp_path / "tour")
    for line in commands[1:]:
        words = shlex.split(line)
        assert words[0] == "somite", line
        assert main(words[1:]) == 0, line
    capsys.readouterr()
    for made in ("runs/worm-0/best.json", "walk.gif", "strip.png", "compare.html", "slow.gif",
                 "gait.png", "brain.png", "runs.png",
                 "reasm/report.json", "reopt/transfer.csv", "modules/partition.json",
                 "lib/back.json", "robot/assembled.json", "report-smoke/index.md"):
        assert (tmp_path / "tour" / made).is_file(), made


def test_the_python_block_runs():
    names: dict = {}
    exec(compile(_block("api", "python"), "README.md", "exec"), names)
    assert len(names["ea"].log) == 3 and len(names["outcomes"]) == 2  # generations 0, 1, 2
    assert names["velocities"].shape == (1, 2)
    assert names["recording"].n_steps == 300  # 5 s at 60 Hz
