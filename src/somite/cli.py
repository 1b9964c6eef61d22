"""The ``somite`` command line: one sub-command per module of :mod:`somite.commands`.

Bad input never ends in a traceback: a :class:`~somite.errors.SomiteError` (or an argparse
error) prints one line, ``somite <command>: error: <field>=<value>: <why>``, and exits with 2.
"""

from __future__ import annotations

import argparse
import pkgutil
import sys

from . import commands
from .errors import SomiteError, bad


def command_names() -> list[str]:
    """Every module of :mod:`somite.commands` except the shared helpers is a sub-command."""
    names = (m.name for m in pkgutil.iter_modules(commands.__path__))
    return sorted(n for n in names if not n.startswith("_") and n != "common")


class _Help(argparse.HelpFormatter):
    """Every option's help ends with its default, unless it names one itself."""

    def _get_help_string(self, action):  # argparse's hook
        text = action.help or ""
        if (not action.option_strings or "default" in text
                or action.default in (None, False, (), argparse.SUPPRESS)):
            return text
        return f"{text} (default: %(default)s)" if text else "default: %(default)s"


class _Parser(argparse.ArgumentParser):
    """argparse, but errors are one line (no usage dump) with exit code 2, and help shows
    every default."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _Help)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # noqa: D102 - argparse's hook
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    from importlib import import_module

    parser = _Parser(
        prog="somite",
        description="Evolve embodied, modular neural controllers for 2-D voxel-based soft "
        "robots. `somite COMMAND --help` gives each command's options.",
    )
    from importlib.metadata import version

    parser.add_argument("--version", action="version", version=f"somite {version('somite')}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in command_names():
        module = import_module(f".commands.{name}", __package__)
        command = sub.add_parser(name.replace("_", "-"), help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(handler=module.run, prog=command.prog)
    return parser


def main(argv: list[str] | None = None) -> int:
    # A file name that is not UTF-8 (bytes given on the command line) is printed escaped,
    # not turned into a UnicodeEncodeError after the work is done.
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if getattr(args, "out", None) == "":
            # Path("") is ".": an empty --out would write into the current folder.
            raise bad("out", "", "is empty; name the file or folder to write")
        return int(args.handler(args) or 0)
    except SomiteError as error:
        sys.stderr.write(f"{args.prog}: error: {error}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write(f"{args.prog}: interrupted\n")
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
