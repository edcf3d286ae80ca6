"""``meshwm embed``: watermark a mesh with a mark image (or a 64-bit id) and a key."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK, rounded

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "embed"
HELP = "watermark a mesh with a mark image and a key"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm embed`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Embed the mark (default: the bundled 32×32 logo) or a 64-bit id under the key and "
            "write the marked mesh: the input's own vertices (same count and order, only their "
            "positions move) and faces, unless --grid asks for the paper's output, the "
            "semi-regular N×N grid mesh of the geometry image."
        ),
    )
    parser.add_argument("input", type=Path, help="input mesh file")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    parser.add_argument("--mark", type=Path, help="mark image (PNG, BMP, ...), thresholded")
    parser.add_argument(
        "--id",
        type=options.ident,
        dest="ident",
        metavar="TEXT|HEX",
        help="embed a 64-bit id instead of a mark: up to 16 hex digits or 8 bytes of text "
        "(CRC-32 and Reed-Solomon protected)",
    )
    parser.add_argument(
        "--mark-size",
        type=options.mark_size,
        default=options.DEFAULT_MARK_SIZE,
        help=f"resample the mark to this side ({options.DEFAULT_MARK_SIZE})",
    )
    parser.add_argument(
        "--grid",
        action="store_true",
        help="write the geometry image's N×N grid mesh instead of the input's mesh (--size)",
    )
    options.add_watermark_options(parser, size=True)
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    parser.add_argument(
        "--no-distance", action="store_true", help="skip the MeshLab distance measurements"
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Embed into ``args.input`` and write ``args.output``; print the report."""
    from meshwm.mesh.io import check_output, read_mesh, write_mesh
    from meshwm.message.mark import default_mark, load_mark
    from meshwm.watermark import embed

    check_output(args.output, overwrite_input=args.input, force=args.force)
    params = options.watermark_params(args)
    if args.ident is not None and args.mark:
        raise ValueError("--id and --mark exclude each other: embed a mark or an id")
    if args.ident is not None:
        mark = None
    else:
        mark = (
            load_mark(args.mark, size=args.mark_size) if args.mark else default_mark(args.mark_size)
        )
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    result = embed(
        vertices,
        faces,
        mark,
        key=args.key,
        params=params,
        max_faces=args.max_faces,
        distances=not args.no_distance,
        ident=args.ident,
        grid=args.grid,
    )
    write_mesh(
        args.output, result.vertices, result.faces, overwrite_input=args.input, force=args.force
    )
    report = {"input": str(args.input), "output": str(args.output), **result.report}
    report["seconds"] = round(report["seconds"], 3)
    if args.json:
        print(json.dumps(rounded(report), indent=2, sort_keys=True))
    else:
        _print_report(report)
    return EXIT_OK


def _print_report(report: dict[str, Any]) -> None:
    lines = [
        f"{report['input']} -> {report['output']}",
        (
            f"  id   : {report['id']} ({report['used_bits']} code bits "
            if "id" in report
            else f"  mark : {report['mark_size']}×{report['mark_size']} = "
            f"{report['used_bits']} bits "
        )
        + f"on {report['carriers']} coefficients (capacity {report['capacity_bits']}), "
        f"N={report['n']}" + (")" if "id" in report else ""),
        f"  PSNR : {report['psnr']:.2f} dB",
    ]
    if report["used_bits"] > report["capacity_bits"]:
        lines.append(
            f"  note : the mark exceeds the capacity at N={report['n']} "
            f"({report['carriers_per_bit_min']} carriers for some bits); a larger --size "
            "or a smaller --mark-size makes it more robust"
        )
    if report.get("mode") == "kept":
        lines.append(
            f"  mesh : kept, {report['vertices']} vertices and {report['faces']} faces as given"
        )
    if "mrms_rel" in report and report.get("mode") == "kept":
        lines.append(
            f"  output vs input: MRMS {100 * report['mrms_rel']:.4f}%, Hausdorff "
            f"{100 * report['hausdorff_rel']:.3f}% of the bbox diagonal"
        )
    elif "mrms_rel" in report:
        lines.append(
            f"  mark distortion: MRMS {100 * report['mrms_rel']:.4f}% of the bbox diagonal"
        )
        lines.append(
            f"  output vs input: Hausdorff {100 * report['hausdorff_rel']:.3f}%, "
            f"RMS {100 * report['rms_rel']:.4f}%"
        )
    lines.append(f"  time : {report['seconds']:.2f} s")
    print("\n".join(lines))
