"""``meshwm demo``: embed the logo into a bundled mesh, attack it, extract, and show the marks."""

from __future__ import annotations

import argparse
from pathlib import Path

from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "demo"
HELP = "embed the logo into a bundled mesh, attack it, extract, and show the marks"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm demo`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Embeds the default logo into the bundled spot mesh (N=256), runs a few attacks, "
            "extracts, prints a table and writes the meshes and a PNG of the marks."
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
