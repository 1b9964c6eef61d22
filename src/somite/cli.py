"""The ``somite`` command line: one sub-command per module of :mod:`somite.commands`.

Bad input never ends in a traceback: a :class:`~somite.errors.SomiteError` (or an argparse
error) prints one line, ``somite <command>: error: <field>=<value>: <why>``, and exits with 2;
so does, as a last resort, an integer too long for Python to read (its int-string limit).

Standard output that cannot be written is not a traceback either: a closed pipe (``somite
campaign list | head -1``) ends the command quietly with 141 (128 + SIGPIPE, as a shell reports
a tool that SIGPIPE stopped); a full, closed (``>&-``) or otherwise failing standard output
prints one line, ``somite <command>: error: cannot write to standard output (<why>)``, and exits
with 1.
"""

from __future__ import annotations

import argparse
import errno
import os
import pkgutil
import signal
import sys
import threading

from . import commands
from .commands._environment import check_environment
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
    # The package's own version, not the installed metadata's: a source tree on PYTHONPATH (a
    # cluster node, a machine without pip) has none, and the tests keep the two equal.
    from somite import __version__

    parser.add_argument("--version", action="version", version=f"somite {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in command_names():
        module = import_module(f".commands.{name}", __package__)
        command = sub.add_parser(name.replace("_", "-"), help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(handler=module.run, prog=command.prog)
    return parser


EXIT_BROKEN_PIPE = 141
"""The exit code when the reader of standard output went away (128 + SIGPIPE)."""
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143
"""The exit codes of a command stopped by Ctrl-C (128 + SIGINT) or SIGTERM (128 + SIGTERM)."""


class _StdoutFailed(Exception):
    """Writing or flushing standard output failed; the OSError (or ValueError) is the cause."""


class _ClosedStdout:
    """``sys.stdout`` of a process started with standard output closed (``>&-``, when Python
    sets it to None): writing anything fails, as in any Unix tool."""

    encoding = "utf-8"
    errors = "strict"

    def write(self, text: str) -> int:
        if text:
            raise OSError(errno.EBADF, "it is closed")
        return 0

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False


class _GuardedStdout:
    """``sys.stdout`` while :func:`main` runs: a failed write or flush raises
    :class:`_StdoutFailed`, so that main tells a closed, full or broken standard output from
    any other OSError; everything else is the real stream's."""

    def __init__(self, stream) -> None:
        self._stream = stream

    def _guard(self, call, *args):
        try:
            return call(*args)
        except UnicodeError:
            raise
        except (OSError, ValueError) as error:  # ValueError: "I/O operation on closed file"
            raise _StdoutFailed() from error

    def write(self, text: str):
        return self._guard(self._stream.write, text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        self._guard(self._stream.flush)

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def _say(line: str) -> None:
    """Write ``line`` on stderr, if stderr can still be written."""
    try:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
    except (AttributeError, OSError, ValueError):  # stderr closed (None), full or broken
        pass


def _to_devnull(stream) -> None:
    """Point ``stream``'s file descriptor at /dev/null, so that the flush of its buffer when
    Python exits does not fail again (the recipe of the Python docs' signal module notes)."""
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):  # no descriptor (pytest's capture, None)
        return
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, fd)
        os.close(devnull)
    except OSError:
        pass


def _hold_fd_1() -> None:
    """With standard output closed, put /dev/null on descriptor 1, so that no file somite
    opens (nor a worker process's output) lands there."""
    try:
        os.fstat(1)
    except OSError:
        try:
            fd = os.open(os.devnull, os.O_WRONLY)
            if fd != 1:
                os.dup2(fd, 1)
                os.close(fd)
        except OSError:
            pass


def _stdout_failed(prog: str, error: BaseException | None, stream) -> int:
    _to_devnull(stream)
    if isinstance(error, BrokenPipeError):
        return EXIT_BROKEN_PIPE
    reason = getattr(error, "strerror", None) or str(error) or type(error).__name__
    _say(f"{prog}: error: cannot write to standard output ({reason})")
    return 1


def _too_long_integer(error: ValueError) -> bool:
    """Whether ``error`` is Python's refusal to read (or print) an integer of too many digits."""
    return "integer string conversion" in str(error)


class _Terminated(KeyboardInterrupt):
    """SIGTERM (``timeout``, a cluster's scheduler, ``kill``), unwound like Ctrl-C: every
    ``finally`` runs, so no temporary file of an unfinished write is left behind."""


class _Stopping:
    """The handler of SIGINT and SIGTERM while :func:`main` runs: the first of them unwinds
    the command (KeyboardInterrupt, or :class:`_Terminated`); any later one is ignored, so
    that it cannot raise again inside a ``finally`` or inside the "interrupted" message (a
    Ctrl-C followed by a ``kill`` gave two tracebacks)."""

    def __init__(self) -> None:
        self.signalled = False

    def __call__(self, signum, frame):
        if self.signalled:
            return
        self.signalled = True
        raise _Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


_STOPPED_BY = (signal.SIGINT, signal.SIGTERM)


def main(argv: list[str] | None = None) -> int:
    """Run ``somite ARGV``; the exit code. Without ``argv`` (the ``somite`` program itself,
    reading ``sys.argv``), an interrupted command ends the process at once when a kernel is
    still running on a helper thread (a first compile takes minutes and cannot be stopped;
    every ``finally`` of the command has run, so nothing half-written is left)."""
    # Only the main thread may set a handler; a command run from a worker's thread keeps its
    # process's own.
    in_main = threading.current_thread() is threading.main_thread()
    previous = {}
    if in_main:
        handler = _Stopping()
        previous = {s: signal.signal(s, handler) for s in _STOPPED_BY}
    try:
        code = _main(argv)
    finally:
        for number, before in previous.items():
            if argv is None and handler.signalled:
                # The program is stopping: a signal after the first still must not kill it
                # with another exit code, nor raise on its way out.
                signal.signal(number, signal.SIG_IGN)
            else:
                signal.signal(number, signal.SIG_DFL if before is None else before)
    if argv is None and code in (EXIT_INTERRUPTED, EXIT_TERMINATED) and _helpers_running():
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (AttributeError, OSError, ValueError):
                pass
        os._exit(code)
    return code


def _helpers_running() -> bool:
    """Whether a helper thread of :func:`somite._threads.spread` is still alive."""
    from ._threads import THREAD_NAME

    return any(t.name.startswith(THREAD_NAME) and t.is_alive() for t in threading.enumerate())


def _main(argv: list[str] | None) -> int:
    # A file name that is not UTF-8 (bytes given on the command line) is printed escaped,
    # not turned into a UnicodeEncodeError after the work is done.
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    original = sys.stdout
    if original is None:
        _hold_fd_1()
    guarded = sys.stdout = _GuardedStdout(original if original is not None else _ClosedStdout())
    prog = ["somite"]
    try:
        try:
            return _run(argv, prog)
        finally:
            # Inside the guard: a full or closed stdout fails here, not when Python exits.
            guarded.flush()
    except _StdoutFailed as failure:
        return _stdout_failed(prog[0], failure.__cause__, original)
    except BrokenPipeError as error:  # written past the guard (a stream kept from before main)
        return _stdout_failed(prog[0], error, original)
    finally:
        sys.stdout = original


def _run(argv: list[str] | None, prog: list[str]) -> int:
    """Parse ``argv`` and run its command; ``prog[0]`` becomes the command's name."""
    try:
        # Before the commands' imports, which would fail on it with a traceback.
        check_environment()
    except SomiteError as error:
        _say(f"somite: error: {error}")
        return 2
    parser = build_parser()
    args = parser.parse_args(argv)
    prog[0] = args.prog
    try:
        if getattr(args, "out", None) == "":
            # Path("") is ".": an empty --out would write into the current folder.
            raise bad("out", "", "is empty; name the file or folder to write")
        return int(args.handler(args) or 0)
    except SomiteError as error:
        _say(f"{args.prog}: error: {error}")
        return 2
    except _Terminated:
        _say(f"{args.prog}: terminated")
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        _say(f"{args.prog}: interrupted")
        return EXIT_INTERRUPTED
    except OSError as error:
        if error.errno != errno.ENAMETOOLONG:
            raise
        # The last resort: a path looked at (is it a folder? is it there?) before it is read,
        # by code that does not expect the look itself to fail.
        _say(f"{args.prog}: error: {bad('path', error.filename, error.strerror)}")
        return 2
    except ValueError as error:
        if not _too_long_integer(error):
            raise
        # The last resort: a parser that reads an integer without checking its length first.
        _say(f"{args.prog}: error: a number has more than {sys.get_int_max_str_digits()} "
             "digits (Python's limit for reading an integer); give a shorter one")
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
