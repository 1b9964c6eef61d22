"""The README teaches what works: its tutorial runs pasted into a new shell right after
``make demo``, every ``somite`` command it and the user guide (docs/guide.md) show parses, and
the guide's Python block runs."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from somite.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GUIDE = ROOT / "docs" / "guide.md"
"""The user guide, where the README's reference went: its blocks are tested as the README's."""


def _text() -> str:
    return README.read_text() + "\n" + GUIDE.read_text()


def _block(marker: str, language: str) -> str:
    """The fenced block of ``language`` right after the HTML comment ``marker`` (in the README
    or the user guide)."""
    text = _text()
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
    text = _text()
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


ACTIVATE = ". .venv/bin/activate"
"""The tutorial's first line: ``make demo`` installs into .venv without activating it."""


def test_make_demo_ends_with_the_tutorial_s_first_line():
    commands = _commands(_block("tutorial", "sh"))
    assert commands[:2] == [ACTIVATE, "mkdir tour && cd tour"]
    makefile = (ROOT / "Makefile").read_text()
    assert "VENV := .venv\n" in makefile and "BIN := $(VENV)/bin\n" in makefile
    recipe = makefile[makefile.index("\ndemo:"):].split("\n\n")[0].splitlines()
    assert recipe[-1].endswith(" . $(BIN)/activate\"") and "echo" in recipe[-1], recipe


def test_the_tutorial_runs_pasted_into_a_fresh_shell(tmp_path):
    """The block as written, by bash, in a shell that has nothing of the tests' environment:
    the PATH of a new login (no somite on it), in a folder holding the clone's .venv."""
    venv = Path(sys.prefix)
    if not (venv / "bin" / "activate").is_file():
        pytest.skip("the tests do not run in a virtual environment (make test makes one)")
    (tmp_path / ".venv").symlink_to(venv)
    env = {"HOME": str(tmp_path), "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8"}
    result = subprocess.run(["bash", "-e", "-c", _block("tutorial", "sh")], cwd=tmp_path,
                            env=env, capture_output=True, text=True, timeout=3600)
    assert result.returncode == 0, (result.stdout[-2000:], result.stderr[-4000:])
    for made in ("runs/worm-0/best.json", "walk.gif", "strip.png", "compare.html", "slow.gif",
                 "gait.png", "brain.png", "runs.png",
                 "reasm/report.json", "reopt/transfer.csv", "modules/partition.json",
                 "lib/back.json", "robot/assembled.json", "report-smoke/index.md"):
        assert (tmp_path / "tour" / made).is_file(), made
    # What it printed is what the README says it prints: v_x and the inherited settings.
    assert "settings: training on flat (from " in result.stdout, result.stdout


def test_the_python_block_runs():
    names: dict = {}
    exec(compile(_block("api", "python"), "README.md", "exec"), names)
    assert len(names["ea"].log) == 3 and len(names["outcomes"]) == 2  # generations 0, 1, 2
    assert names["velocities"].shape == (1, 2) and names["unseen"].shape == (1, 2)
    assert not np.array_equal(names["unseen"], names["velocities"])
    assert names["recording"].n_steps == 300  # 5 s at 60 Hz
