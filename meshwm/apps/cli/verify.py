"""``meshwm verify``: do files carry the mark or the id?  Exit 0 present, 1 absent, 2 error.

Every file goes through :func:`meshwm.apps.batch.verify_file` (every mesh of it read); several
files, folders and globs run in parallel processes or on a Dask cluster.  Without ``--mark``,
``--id`` or ``--any-id`` the bundled logo is sought, as ``embed`` marks it by default.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_ABSENT, EXIT_OK, rounded, together_text

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "verify"
HELP = "decide whether files carry a mark or an id (exit 0 present, 1 absent, 2 error)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm verify`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Read every mesh of each file and compare with the expected mark (default: the "
            "bundled logo) or id: present when the bit agreement is significant, p-value below "
            "--fpr divided by the number of hypotheses the decoder tried (binomial test, "
            "fair-coin null, Bonferroni); a file is present when one of its meshes is. When "
            "the mark is absent because the mesh carries an id (or the reverse), it says so. "
            "The decision and batches: meshwm docs verify."
        ),
    )
    parser.add_argument(
        "input", type=Path, nargs="+", help="mesh files, folders (searched recursively) or globs"
    )
    what = parser.add_mutually_exclusive_group()
    what.add_argument(
        "--mark", type=Path, help="the expected mark image (default: the bundled logo)"
    )
    what.add_argument(
        "--id",
        dest="id_text",
        metavar="ID",
        help="the expected id: 0x and hex digits, anything else is text (up to 8 bytes)",
    )
    what.add_argument(
        "--any-id", action="store_true", help="present when any valid id decodes (reports it)"
    )
    parser.add_argument(
        "--mark-size",
        type=options.mark_size,
        default=options.DEFAULT_MARK_SIZE,
        help=f"side of the square mark ({options.DEFAULT_MARK_SIZE})",
    )
    options.add_fpr_option(parser)
    parser.add_argument(
        "--jobs",
        type=options.positive_int,
        default=1,
        help="files checked in parallel processes (1)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://host:8786); needs pip install 'meshwm[dask]'",
    )
    parser.add_argument(
        "--jsonl", action="store_true", help="one JSON line per file, then a summary line"
    )
    parser.add_argument(
        "--registry",
        metavar="DB",
        help="a registry (file or PostgreSQL URL): a mesh the blind readers miss is traced "
        "to a registered copy by the informed reader, which the report names",
    )
    options.add_watermark_options(parser, size=False)
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Verify ``args.input``; the exit code is the verdict."""
    from meshwm.apps.batch import Check, expand_paths, run_dask, run_local, summarise, verify_file
    from meshwm.apps.progress import ProgressBar, Status
    from meshwm.message.mark import default_mark, load_mark

    ident = None
    if args.id_text is not None:
        try:
            ident = options.ident(args.id_text)
        except argparse.ArgumentTypeError as exc:  # a usage error, reported as argparse would
            raise ValueError(f"argument --id: {exc}") from None
    mark = None
    if ident is None and not args.any_id:
        mark = (
            load_mark(args.mark, size=args.mark_size) if args.mark else default_mark(args.mark_size)
        )
    check = Check(
        key=options.key_of(args),
        params=options.watermark_params(args),
        mark=mark,
        ident=ident,
        ident_text=args.id_text,
        any_id=args.any_id,
        fpr=args.fpr,
        max_faces=args.max_faces,
        registry=args.registry,
    )
    from meshwm.message.payload import format_id

    what = "mark" if mark is not None else (f"id {format_id(ident)}" if ident else "an id")
    paths = expand_paths(args.input)
    if not paths:
        raise ValueError("no mesh files found in the given paths")
    one = len(args.input) == 1 and len(paths) == 1 and paths[0] == args.input[0]
    if one and not args.jsonl and not args.scheduler:
        with Status(sys.stderr) as status:
            status.stage(f"reading {paths[0]}")
            row = verify_file(paths[0], check, progress=status.stage)
        if row["error"]:
            raise ValueError(row["error"])
        if args.json:
            report = {"input": row.pop("path"), "fpr": args.fpr, **row}
            print(json.dumps(_json_ready(report), indent=2, sort_keys=True))
        else:
            _print_row(row, what)
        return EXIT_OK if row["detected"] else EXIT_ABSENT
    bar = None
    if not args.jsonl and not args.json and sys.stderr.isatty():
        bar = ProgressBar(sys.stderr, width=30, unit="files")
    if args.scheduler:
        rows_iter = run_dask(paths, check, scheduler=args.scheduler)
    else:
        rows_iter = run_local(paths, check, jobs=args.jobs)
    rows = []
    for row in rows_iter:
        rows.append(row)
        if bar is not None:
            bar.clear()  # a result never shares a line with the bar
        if args.jsonl:
            print(json.dumps(_json_ready(row), sort_keys=True), flush=True)
        elif not args.json:
            _print_row(row, what)
        if bar is not None:
            bar(len(rows), len(paths))
    summary = summarise(rows)
    if args.jsonl:
        print(json.dumps({"summary": rounded(summary)}, sort_keys=True))
    elif args.json:
        files = [_json_ready(r) for r in rows]
        print(json.dumps({"files": files, "summary": rounded(summary)}, indent=2))
    else:
        print(
            f"{summary['files']} files: {summary['present']} present, {summary['absent']} "
            f"absent, {summary['errors']} unreadable"
        )
    return int(summary["exit_code"])


def _json_ready(row: dict[str, Any]) -> dict[str, Any]:
    out = rounded(row)
    if "meshes" in out:
        out["meshes"] = [rounded(m) for m in out["meshes"]]
    return out


def _verdict(row: dict[str, Any], what: str) -> str:
    """``mark present (BER 0.0000, p-value 1e-300)``, and what the mesh carries instead."""
    from meshwm.message.payload import format_id

    if row.get("error"):
        return f"error ({row['error']})"
    if what == "an id" and row.get("id") and row["detected"]:
        what = f"id {format_id(row['id'])}"
    details = []
    if row.get("ber") is not None:
        details.append(f"BER {row['ber']:.4f}, p-value {row['p_value']:.3g}")
    if row.get("reason"):
        details.append(row["reason"])
    if row.get("piece"):
        piece = row["piece"]
        details.append(
            f"read in piece {piece['index']} of {piece['of']} ({piece['vertices']} vertices) alone"
        )
    if row.get("together"):
        details.append(together_text(row["together"]))
    if row.get("reader") == "informed (registry)":
        found = row.get("informed") or {}
        details.append(
            f"informed reader (registry): asset {found.get('asset')!r}, copy "
            f"#{found.get('copy_id')} for {found.get('recipient') or 'no recipient recorded'}"
            + (", read vertex by vertex" if found.get("correspondence") == "vertices" else "")
            + f", p-value {row['p_value']:.3g} over {row['hypotheses']} hypotheses"
        )
    text = f"{what} {'present' if row['detected'] else 'absent'}"
    text += f" ({'; '.join(details)})" if details else ""
    return text + (f": {row['note']}" if row.get("note") else "")


def _print_row(row: dict[str, Any], what: str) -> None:
    meshes = row.get("meshes") or []
    if len(meshes) <= 1 or row.get("error"):
        print(f"{row['path']}: {_verdict(row, what)}", flush=True)
        return
    present = sum(1 for m in meshes if m["detected"])
    print(f"{row['path']}: {what} present in {present} of {len(meshes)} meshes", flush=True)
    for mesh in meshes:
        print(f"  {row['path']} [{mesh['name']}]: {_verdict(mesh, what)}", flush=True)
