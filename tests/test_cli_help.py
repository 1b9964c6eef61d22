"""The command line's help: a version, and every option's default."""

from __future__ import annotations

import argparse

import pytest

import somite
from somite.cli import build_parser, main


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"somite {somite.__version__}\n"


def test_version_is_the_installed_one_and_needs_no_metadata(capsys, monkeypatch):
    import importlib.metadata

    assert importlib.metadata.version("somite") == somite.__version__

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    # As from a source tree on PYTHONPATH, where no package metadata exists.
    monkeypatch.setattr(importlib.metadata, "version", missing)
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out == f"somite {somite.__version__}\n"


def _options(parser: argparse.ArgumentParser, name: str = "somite"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from _options(child, f"{name} {sub}")
        elif action.option_strings and action.dest not in ("help", "version"):
            yield name, parser, action


def test_every_option_says_its_default():
    missing = []
    for name, parser, action in _options(build_parser()):
        if action.required or action.default in (None, False, ()):
            continue  # nothing to say, or said in words where the default is None
        text = parser.formatter_class(parser.prog)._get_help_string(action) or ""
        if "default" not in text:
            missing.append(f"{name} {action.option_strings[0]}")
    assert missing == []


def test_options_whose_default_is_another_file_say_so():
    """Options that take their default from a run or a config file (None in argparse) say it
    in words, e.g. "(default: the genome's run's, else 30)"."""
    helps = {(name, action.option_strings[0]): action.help or ""
             for name, _, action in _options(build_parser())}
    for key in (("somite evaluate", "--duration"), ("somite show", "--terrain"),
                ("somite evolve", "--generations"), ("somite reoptimize", "--generations"),
                ("somite module export", "--partition"), ("somite simulate", "--controller")):
        assert "default" in helps[key], key
    assert "else 510" in helps[("somite reoptimize", "--generations")]
