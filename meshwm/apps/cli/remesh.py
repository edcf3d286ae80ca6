"""``meshwm remesh``: resample a mesh onto a regular N×N grid (a geometry image) and write it."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from meshwm._validate import DEFAULT_SIZE, SIZE_RANGE
from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "remesh"
HELP = "resample a mesh onto a regular N×N grid (a geometry image) and write it"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm remesh`` to ``subparsers``."""
    from meshwm.mesh.io import READ_SUFFIXES, WRITE_SUFFIXES

    low, high = SIZE_RANGE
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Clean the mesh, cut it open to a disk, map it onto the unit square and sample an "
            "N×N grid; write the grid mesh (cut seams welded) plus any other components. "
            f"Reads {', '.join(READ_SUFFIXES)}; writes {', '.join(WRITE_SUFFIXES)}."
        ),
    )
    parser.add_argument("input", type=Path, help="input mesh file")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    parser.add_argument(
        "--size",
        type=options.grid_size,
        default=DEFAULT_SIZE,
        help=f"grid size N, a power of two {low}..{high} ({DEFAULT_SIZE})",
    )
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    options.add_max_faces(parser)
    parser.add_argument(
        "--no-distance",
        action="store_true",
        help="skip the Hausdorff/RMS measurement of the remeshing error (faster)",
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Remesh ``args.input`` into ``args.output``; print the report."""
    from meshwm.gim.remesh import mesh_to_geometry_image
    from meshwm.gim.to_mesh import geometry_image_to_mesh
    from meshwm.mesh.io import check_output, read_mesh, write_mesh
    from meshwm.metrics import surface_distance

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
        _print_report(report)
    return EXIT_OK


def _print_report(r: dict[str, Any]) -> None:
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
