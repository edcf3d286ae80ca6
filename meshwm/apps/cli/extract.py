"""``meshwm extract``: what each mesh of a file carries, blind (the file and the key only).

An id is reported as such (text and hex); a mesh without one is read as a mark, written as a
PNG with ``-o`` and compared with the bundled logo (or ``--mark``).  A mesh that carries an id
gets no mark image: the noise it would read is not written.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path
from typing import Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK, check_png, rounded, together_text

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "extract"
HELP = "read the id or the mark of each mesh of a file (blind: the file and the key only)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm extract`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Read every mesh of the file: report the id it carries, or read its mark, "
            "compare it with the bundled logo (or --mark) and write it as a PNG (-o). A file "
            "of several meshes gets one PNG per mesh, named MARK-<mesh>.png."
        ),
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
    parser.add_argument(
        "--registry",
        metavar="DB",
        help="a registry (file or PostgreSQL URL): a mesh from which no id reads blind is "
        "traced to a registered copy by the informed reader, which the report names",
    )
    options.add_watermark_options(parser, size=False)
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.set_defaults(run=run)
    return parser


def _png_for(output: Path, name: str, several: bool) -> Path:
    if not several:
        return output
    safe = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("_") or "mesh"
    return output.with_name(f"{output.stem}-{safe}.png")


def run(args: argparse.Namespace) -> int:
    """Read ``args.input``; write the marks found, print what each mesh carries."""
    from meshwm.apps.progress import Status
    from meshwm.mesh.asset import read_asset
    from meshwm.message.mark import load_mark, save_mark
    from meshwm.watermark.assets import extract_asset

    key = options.key_of(args)
    if args.output is not None:
        check_png(args.output, [args.input], what="mark")
    expected = load_mark(args.mark, size=args.mark_size) if args.mark else None
    started = time.perf_counter()
    with Status(sys.stderr) as status:
        status.stage(f"reading {args.input}")
        asset = read_asset(args.input, max_faces=args.max_faces)
        rows = extract_asset(
            asset,
            key=key,
            mark_size=args.mark_size,
            expected=expected,
            params=options.watermark_params(args),
            max_faces=args.max_faces,
            progress=status.stage,
        )
        if args.registry:
            _informed(asset, rows, key, args, status.stage)
    if all(row["kind"] is None for row in rows):
        raise ValueError(f"{args.input}: " + "; ".join(row["reason"] for row in rows))
    several = len(rows) > 1
    for row in rows:
        mark = row.pop("mark", None)
        row["output"] = None
        if mark is not None and args.output is not None:
            target = _png_for(args.output, row["name"], several)
            save_mark(target, mark)
            row["output"] = str(target)
    report: dict[str, Any] = {"input": str(args.input), "meshes": [rounded(r) for r in rows]}
    if not several:
        report.update({k: v for k, v in rows[0].items() if k != "name"})
    report["seconds"] = round(time.perf_counter() - started, 3)
    if args.json:
        print(json.dumps(rounded(report), indent=2, sort_keys=True))
    else:
        for row in rows:
            where = f"{args.input} [{row['name']}]" if several else str(args.input)
            print(f"{where}: {_describe(row, args)}")
    return EXIT_OK


def _informed(
    asset: Any, rows: list[dict[str, Any]], key: str | bytes, args: argparse.Namespace, stage: Any
) -> None:
    """Rows without an id read blind: the informed reader (the registry's copies)."""
    from meshwm.apps.registry import Registry
    from meshwm.apps.tracing import trace_mesh

    with Registry.open(args.registry, create=False) as registry:
        for k, row in enumerate(rows):
            if row["kind"] == "id" or asset.meshes[k].reason is not None:
                continue
            stage(f"informed reading of {asset.meshes[k].name}")
            found = trace_mesh(
                asset.vertices(k),
                asset.meshes[k].faces,
                key=key,
                registry=registry,
                fpr=1e-6,
                max_faces=args.max_faces,
            )
            row["informed"] = {
                name: found.get(name)
                for name in ("detected", "asset", "copy_id", "id", "recipient", "p_value")
            }
            row["informed"]["hypotheses"] = found["hypotheses"]
            payload = found.get("id")
            if found["detected"] and not str(payload).startswith("mark:"):
                row.update(kind="id", id=payload, reader="informed (registry)")
                row.pop("reason", None)


def _describe(row: dict[str, Any], args: argparse.Namespace) -> str:
    if row["kind"] is None:
        return f"nothing read ({row['reason']})"
    piece = row.get("piece")
    alone = (
        f" (read in piece {piece['index']} of {piece['of']}, {piece['vertices']} vertices, alone)"
        if piece
        else ""
    )
    if row.get("together"):
        alone = f" ({together_text(row['together'])})"
    return _what(row, args) + alone


def _what(row: dict[str, Any], args: argparse.Namespace) -> str:
    from meshwm.message.payload import format_id

    if row["kind"] == "id":
        text = f"id {format_id(row['id'])}"
        if row.get("reader") == "informed (registry)":
            found = row["informed"]
            text += (
                f" (informed reader, registry: asset {found['asset']!r}, copy "
                f"#{found['copy_id']}, p-value {found['p_value']:.3g} over "
                f"{found['hypotheses']} hypotheses)"
            )
        if args.output is not None:
            text += "; this mesh carries an id, not a mark: no mark image written"
        return text
    side = args.mark_size
    text = f"{side}×{side} mark" + (f" -> {row['output']}" if row["output"] else "")
    if "ber" in row:
        text += f" (BER {row['ber']:.4f}, corr2 {row['correlation']:.4f})"
    elif row.get("logo"):
        text += " (the bundled logo)"
    elif "logo" in row and row.get("drawing"):
        text += " (not the bundled logo: another mark, which reads as a drawing)"
    elif "logo" in row:
        text += (
            " (not the bundled logo, and no drawing: a wrong key, no mark, or a mark that is"
            " not a drawing)"
        )
    return text
