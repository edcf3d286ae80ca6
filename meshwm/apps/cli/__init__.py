"""Command-line interface: ``meshwm <command> ...``.

No algorithm lives here: each command reads its input, calls the library and writes its output.
Any bad input (a file that cannot be read, a mesh that cannot be mapped, a bad option) ends in
one line on stderr and exit code 2, never a traceback and never a partial output file.  Set
``MESHWM_DEBUG=1`` to get the traceback of an unexpected error.  Results go to stdout, progress
to stderr (only on a terminal); when stdout is closed early (``meshwm verify ... | head``) the
command stops quietly with exit code 141, what a tool killed by SIGPIPE reports.

One module per command (:data:`COMMANDS`), each with ``NAME``, a one-line ``HELP``,
``add_parser(subparsers)`` and ``run(args) -> int``; :mod:`~meshwm.apps.cli.options` holds the
option types and the watermark options they share, :mod:`~meshwm.apps.cli.output` the exit codes
and report rounding.  A command module imports the library inside ``run``, and only the command
named on the line gets its options built, so ``meshwm --help``, ``meshwm --version`` and
``meshwm COMMAND --help`` load no mesh, image or plotting library beyond what that command's
options name.
"""

from __future__ import annotations

import argparse
import io
import os
import sys
from collections.abc import Collection, Sequence
from typing import Protocol

from meshwm import __version__
from meshwm._malloc import keep_freed_memory
from meshwm.apps.cli import (
    attack,
    bench,
    demo,
    docs,
    embed,
    extract,
    registry,
    remesh,
    render,
    trace,
    verify,
)
from meshwm.apps.cli.output import EXIT_ERROR

__all__ = ["COMMANDS", "EXIT_PIPE", "build_parser", "main"]

#: Exit code when stdout was closed before the output was written (128 + SIGPIPE).
EXIT_PIPE = 141


class Command(Protocol):
    """What a command module provides."""

    NAME: str
    HELP: str

    def add_parser(self, subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser: ...

    def run(self, args: argparse.Namespace) -> int: ...


#: Command name -> its module, in the order ``meshwm --help`` lists them.
COMMANDS: dict[str, Command] = {
    module.NAME: module
    for module in (
        remesh,
        embed,
        extract,
        verify,
        trace,
        attack,
        render,
        demo,
        bench,
        registry,
        docs,
    )
}


class _UsageError(Exception):
    """A bad command line; carries argparse's message."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line and exit code 2 (not a usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(message)


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The ``meshwm`` parser.

    Parameters
    ----------
    commands : collection of str, optional
        The commands whose options are built (default: all).  The others are listed by name
        and one-line help only, which is all ``meshwm --help`` and an unknown command's error
        show, and which imports nothing they need.

    Returns
    -------
    argparse.ArgumentParser
    """
    parser = _Parser(
        prog="meshwm",
        description="Blind, robust watermarking of 3D triangle meshes (geometry images).",
    )
    parser.add_argument("--version", action="version", version=f"meshwm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name, command in COMMANDS.items():
        if commands is None or name in commands:
            command.add_parser(sub)
        else:
            sub.add_parser(name, help=command.HELP)
    return parser


def _named_command(argv: Sequence[str]) -> list[str]:
    """The command on the line: its first positional word (``meshwm`` takes no option value)."""
    for word in argv:
        if word == "-" or not word.startswith("-"):
            return [word]
    return []


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``meshwm`` command line; return the exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success (for ``verify``: present), 1 for ``verify``: absent, 2 on any error (one
        line on stderr).
    """
    words = list(sys.argv[1:] if argv is None else argv)
    command = _named_command(words)
    parser = build_parser(command)
    try:
        args = parser.parse_args(words)
    except _UsageError as exc:
        print(f"meshwm: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    # Temporaries reuse the memory of the last ones, not fresh zeroed pages (meshwm/_malloc.py):
    # a command keeps its memory until it exits.
    keep_freed_memory(until_exit=True)
    try:
        code = int(args.run(args))
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's last flush
        return code
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_PIPE
    except (ValueError, TypeError, OSError) as exc:
        message = " ".join(str(exc).split()) or type(exc).__name__
        if "more than the limit of" in message and hasattr(args, "max_faces"):
            # A --grid output at N = 2048 has 8.4M faces: over the reader's default.
            message += " (--max-faces raises it)"
        print(f"meshwm: error: {message}", file=sys.stderr)
        return EXIT_ERROR
    except MemoryError:
        print("meshwm: error: out of memory (try a smaller --size or input)", file=sys.stderr)
        return EXIT_ERROR
    except Exception as exc:
        if os.environ.get("MESHWM_DEBUG"):
            raise
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"meshwm: internal error: {type(exc).__name__}: {message}", file=sys.stderr)
        return EXIT_ERROR


def _silence_stdout() -> None:
    """Point stdout at the null device, so the interpreter's last flush cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        pass  # not a real file (a test's capture): nothing will flush to a closed pipe
