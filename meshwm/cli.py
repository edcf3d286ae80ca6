"""Command-line interface: ``meshwm <command> ...``.

No algorithm lives here: each command reads its input, calls the library and writes its output.
Any bad input (a file that cannot be read, a mesh that cannot be mapped, a bad option) ends in
one line on stderr and exit code 2, never a traceback and never a partial output file.  Set
``MESHWM_DEBUG=1`` to get the traceback of an unexpected error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from meshwm import __version__
from meshwm._validate import DEFAULT_MAX_FACES, check_square_pow2
from meshwm.geometry_image import geometry_image_to_mesh, mesh_to_geometry_image
from meshwm.io import READ_SUFFIXES, WRITE_SUFFIXES, check_output, read_mesh, write_mesh
from meshwm.metrics import surface_distance

__all__ = ["main"]

EXIT_OK = 0
EXIT_ERROR = 2


class _UsageError(Exception):
    """A bad command line; carries argparse's message."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line and exit code 2 (not a usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(message)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def _size(text: str) -> int:
    try:
        return check_square_pow2(_positive_int(text), name="--size")
    except (TypeError, ValueError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="meshwm",
        description="Blind, robust watermarking of 3D triangle meshes (geometry images).",
    )
    parser.add_argument("--version", action="version", version=f"meshwm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    remesh = sub.add_parser(
        "remesh",
        help="resample a mesh onto a regular N×N grid (a geometry image) and write it",
        description=(
            "Clean the mesh, cut it open to a disk, map it onto the unit square and sample an "
            "N×N grid; write the grid mesh (cut seams welded) plus any other components. "
            f"Reads {', '.join(READ_SUFFIXES)}; writes {', '.join(WRITE_SUFFIXES)}."
        ),
    )
    remesh.add_argument("input", type=Path, help="input mesh file")
    remesh.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    remesh.add_argument(
        "--size", type=_size, default=256, help="grid size N, a power of two 64..2048 (256)"
    )
    remesh.add_argument("--json", action="store_true", help="print the report as JSON")
    remesh.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    remesh.add_argument(
        "--max-faces",
        type=_positive_int,
        default=DEFAULT_MAX_FACES,
        help=f"refuse inputs with more faces ({DEFAULT_MAX_FACES})",
    )
    remesh.add_argument(
        "--no-distance",
        action="store_true",
        help="skip the Hausdorff/RMS measurement of the remeshing error (faster)",
    )
    remesh.set_defaults(run=_run_remesh)
    return parser


def _run_remesh(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    check_output(args.output, overwrite_input=args.input, force=args.force)
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    gi = mesh_to_geometry_image(vertices, faces, size=args.size, max_faces=args.max_faces)
    out_v, out_f = geometry_image_to_mesh(
        gi.gim, gi.weld, other_vertices=gi.other_vertices, other_faces=gi.other_faces
    )
    write_mesh(args.output, out_v, out_f, overwrite_input=args.input, force=args.force)
    seconds = time.perf_counter() - started
    report = {
        "input": str(args.input),
        "output": str(args.output),
        "vertices_in": len(vertices),
        "faces_in": len(faces),
        "vertices_out": len(out_v),
        "faces_out": len(out_f),
        "n": gi.report["n"],
        "seconds": round(seconds, 3),
    }
    report.update({k: v for k, v in gi.report.items() if k not in report})
    if not args.no_distance:
        d = surface_distance(vertices, faces, out_v, out_f)
        report["hausdorff_rel"] = d.hausdorff / d.diagonal
        report["rms_rel"] = d.rms / d.diagonal
    if args.json:
        print(json.dumps(report, indent=2, sort_keys=True))
    else:
        _print_remesh(report)
    return EXIT_OK


def _print_remesh(r: dict) -> None:
    lines = [
        f"{r['input']} -> {r['output']}",
        f"  in : {r['vertices_in']} vertices, {r['faces_in']} faces "
        f"(genus {r['genus']}, {r['boundary_loops']} boundary loops, "
        f"{r['components']} components)",
        f"  out: {r['vertices_out']} vertices, {r['faces_out']} faces, N={r['n']} "
        f"({r['components_passed_through']} other components passed through)",
        f"  cut: {r['cut_paths']} paths, {r['chains']} chains; "
        f"flipped triangles: {r['flipped_triangles']}",
    ]
    if "hausdorff_rel" in r:
        lines.append(
            f"  error: Hausdorff {100 * r['hausdorff_rel']:.3f}% and RMS {100 * r['rms_rel']:.4f}% "
            "of the bounding-box diagonal"
        )
    lines.append(f"  time : {r['seconds']:.2f} s")
    print("\n".join(lines))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``meshwm`` command line; return the exit code.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 on any error (one line on stderr).
    """
    parser = _build_parser()
    try:
        args = parser.parse_args(argv)
    except _UsageError as exc:
        print(f"meshwm: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    try:
        return int(args.run(args))
    except (ValueError, TypeError, OSError) as exc:
        message = " ".join(str(exc).split()) or type(exc).__name__
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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
