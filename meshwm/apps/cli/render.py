"""``meshwm render``: shaded views of a mesh as a PNG, or a heat map of its distance to another."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK, check_png, rounded

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "render"
HELP = "draw shaded views of a mesh as a PNG, or a heat map of its distance to another"

# meshwm.apps.render's VIEWS_RANGE and SIZE_RANGE, not imported: matplotlib and igl would then
# load with the parser (tests/apps/test_render.py checks that they agree).
VIEWS_RANGE = (1, 12)
WIDTH_RANGE = (100, 4000)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm render`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Draw a row of flat-shaded orthographic views of the mesh. With --compare, colour "
            "it by the distance from each of its vertices to the surface of OTHER, in % of "
            "OTHER's bounding-box diagonal. meshwm docs render describes the pictures."
        ),
    )
    parser.add_argument("input", type=Path, help="mesh file to draw")
    parser.add_argument("-o", "--output", type=Path, required=True, help="picture to write (.png)")
    parser.add_argument(
        "--compare", type=Path, metavar="OTHER", help="reference mesh: draw the distance to it"
    )
    parser.add_argument(
        "--views",
        type=options.bounded("a number of views", *VIEWS_RANGE),
        default=3,
        metavar="N",
        help=f"number of views side by side, {VIEWS_RANGE[0]}..{VIEWS_RANGE[1]} (3)",
    )
    parser.add_argument(
        "--size",
        type=options.bounded("a width", *WIDTH_RANGE),
        default=900,
        metavar="PX",
        help=f"picture width in pixels, {WIDTH_RANGE[0]}..{WIDTH_RANGE[1]} (900)",
    )
    parser.add_argument(
        "--texture",
        action="store_true",
        help="colour each face by the file's texture (its UVs and material image, e.g. an "
        "OBJ's .mtl), vertex colours or material colour",
    )
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--force", action="store_true", help="allow the output to overwrite an input file"
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Draw ``args.input`` (against ``args.compare``) into ``args.output``; print the report."""
    from meshwm._atomic import write_atomic
    from meshwm.apps.render import render_comparison, render_views
    from meshwm.mesh.io import read_mesh

    started = time.perf_counter()
    out = args.output
    check_png(out, [args.input, args.compare], what="picture", force=args.force)
    report: dict[str, Any] = {"input": str(args.input), "output": str(out)}
    if args.texture and args.compare is not None:
        raise ValueError("--texture and --compare exclude each other: draw a look or a distance")
    if args.texture:
        from meshwm.apps.texture import texture_colors

        look = texture_colors(args.input)
        vertices, faces = look.vertices, look.faces
        report["textured_faces"] = look.textured
        png = render_views(
            vertices,
            faces,
            views=args.views,
            size=args.size,
            title=args.input.name,
            face_colors=look.colors,
        )
    elif args.compare is None:
        vertices, faces = read_mesh(args.input)
        png = render_views(vertices, faces, views=args.views, size=args.size, title=args.input.name)
    else:
        vertices, faces = read_mesh(args.input)
        other_v, other_f = read_mesh(args.compare)
        png, stats = render_comparison(
            vertices,
            faces,
            other_v,
            other_f,
            views=args.views,
            size=args.size,
            title=f"{args.input.name} vs {args.compare.name}",
        )
        report["compare"] = str(args.compare)
        report.update(stats)
    write_atomic(out, png)
    report.update(
        views=args.views,
        size=args.size,
        width=int.from_bytes(png[16:20], "big"),  # from the PNG header (IHDR)
        height=int.from_bytes(png[20:24], "big"),
        faces=len(faces),
        seconds=round(time.perf_counter() - started, 3),
    )
    if args.json:
        print(json.dumps(rounded(report), indent=2, sort_keys=True))
    else:
        _print_report(args, report)
    return EXIT_OK


def _print_report(args: argparse.Namespace, report: dict[str, Any]) -> None:
    line = (
        f"{report['input']} -> {report['output']}: {args.views} "
        f"view{'s' if args.views > 1 else ''}, "
        f"{report['width']}×{report['height']} px"
    )
    if args.compare is not None:
        line += (
            f"; distance to {report['compare']}: max {100 * report['max_rel']:.4f}%, "
            f"mean {100 * report['mean_rel']:.4f}%, RMS {100 * report['rms_rel']:.4f}% "
            "of its bounding-box diagonal"
        )
    print(f"{line} ({report['seconds']:.2f} s)")
