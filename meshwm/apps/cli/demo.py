"""``meshwm demo``: mark a bundled mesh with an id (its mesh kept), attack it, read it back."""

from __future__ import annotations

import argparse
from pathlib import Path

from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "demo"
HELP = "mark a bundled mesh with an id (its mesh kept), attack it and read the id back"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm demo`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Marks the bundled spot mesh with a 64-bit id, keeping its vertices and faces, runs "
            "the attacks a pipeline does to a file, reads the id back blind from each, prints a "
            "table and writes the meshes and a picture of where the mark moved the surface."
        ),
    )
    parser.add_argument(
        "--out", type=Path, default=Path("meshwm-demo"), help="output folder (meshwm-demo)"
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run :func:`meshwm.apps.demo.run_demo` into ``args.out``."""
    from meshwm.apps.demo import run_demo

    run_demo(args.out)
    return EXIT_OK
