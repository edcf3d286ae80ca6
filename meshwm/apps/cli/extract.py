"""``meshwm extract``: read the mark from a mesh, blind (the mesh and the key only)."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK, check_png, rounded

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "extract"
HELP = "read the mark from a mesh (blind: the mesh and the key only)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm extract`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Find the grid in the mesh, read the mark and write it as a PNG.",
    )
    parser.add_argument("input", type=Path, help="received mesh file")
    parser.add_argument("-o", "--output", type=Path, help="mark image to write (.png)")
    parser.add_argument(
        "--mark-size",
        type=options.mark_size,
        default=options.DEFAULT_MARK_SIZE,
        help=f"side of the square mark ({options.DEFAULT_MARK_SIZE})",
    )
    parser.add_argument("--mark", type=Path, help="the original mark, to report BER and corr2")
    options.add_watermark_options(parser, size=False)
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Extract the mark of ``args.input``; write it to ``args.output`` and/or print the report.

    The mesh is read once (one :class:`meshwm.watermark.Decoder`) for the mark and, with
    ``--json``, for the id it may carry.
    """
    from meshwm.mesh.io import read_mesh
    from meshwm.message.mark import load_mark, save_mark
    from meshwm.watermark import Decoder

    if args.output is None and not args.json:
        raise ValueError("give -o MARK.png to write the mark, or --json to print the report")
    if args.output is not None:
        check_png(args.output, [args.input], what="mark")
    expected = load_mark(args.mark, size=args.mark_size) if args.mark else None
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    started = time.perf_counter()
    reader = Decoder(
        vertices, faces, params=options.watermark_params(args), max_faces=args.max_faces
    )
    result = reader.extract(key=args.key, mark_size=args.mark_size, expected=expected)
    result.report["seconds"] = time.perf_counter() - started  # as meshwm.watermark.extract
    report = {"input": str(args.input), "output": None, **result.report}
    if args.output is not None:
        save_mark(args.output, result.mark)
        report["output"] = str(args.output)
    if args.json:
        # The id payload, if the mesh carries one (None otherwise: the CRC decides).
        report["id"] = reader.extract_id(key=args.key).id
        print(json.dumps(rounded(report), indent=2, sort_keys=True))
    else:
        line = f"{args.input}: {args.mark_size}×{args.mark_size} mark -> {args.output}"
        if expected is not None:
            line += f" (BER {report['ber']:.4f}, corr2 {report['correlation']:.4f})"
        print(line)
    return EXIT_OK
