"""``meshwm verify``: decide whether meshes carry a mark (exit 0 present, 1 absent, 2 error).

One file with ``--mark`` is decided here; several files, folders, globs, an id or
``--jsonl`` go through :mod:`meshwm.apps.batch` (parallel processes or a Dask cluster).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_ABSENT, EXIT_OK, rounded

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "verify"
HELP = "decide whether a mesh carries a mark (exit 0 present, 1 absent, 2 error)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm verify`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Extract and compare with the expected mark: present when the bit agreement is "
            "significant: p-value below --fpr divided by the number of hypotheses the decoder "
            "tried (binomial test, fair-coin null, Bonferroni)."
        ),
    )
    parser.add_argument(
        "input", type=Path, nargs="+", help="mesh files, folders (searched recursively) or globs"
    )
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--mark", type=Path, help="the expected mark image")
    what.add_argument(
        "--id", type=options.ident, dest="ident", metavar="TEXT|HEX", help="the expected id"
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
    parser.add_argument(
        "--fpr",
        type=options.probability,
        default=1e-6,
        help="false-positive probability allowed, over all hypotheses tried (1e-6)",
    )
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
    options.add_watermark_options(parser, size=False)
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Verify ``args.input``; the exit code is the verdict."""
    if len(args.input) == 1 and args.mark and not args.jsonl and not args.scheduler:
        args.input = args.input[0]
        return _verify_one(args)
    return _verify_batch(args)


def _verify_batch(args: argparse.Namespace) -> int:
    """Many files (or an id): one row per file, a summary, exit 0 / 1 / 2 (meshwm.apps.batch)."""
    from meshwm.apps.batch import Check, expand_paths, run_dask, run_local, summarise
    from meshwm.apps.progress import progress_bar
    from meshwm.message.mark import load_mark

    check = Check(
        key=args.key,
        params=options.watermark_params(args),
        mark=load_mark(args.mark, size=args.mark_size) if args.mark else None,
        ident=args.ident,
        any_id=args.any_id,
        fpr=args.fpr,
        max_faces=args.max_faces,
    )
    paths = expand_paths(args.input)
    if not paths:
        raise ValueError("no mesh files found in the given paths")
    show = None
    if not args.jsonl and not args.json and sys.stderr.isatty():
        show = progress_bar(len(paths), sys.stderr)
    if args.scheduler:
        rows_iter = run_dask(paths, check, scheduler=args.scheduler)
    else:
        rows_iter = run_local(paths, check, jobs=args.jobs)
    rows = []
    for row in rows_iter:
        rows.append(row)
        if args.jsonl:
            print(json.dumps(rounded(row), sort_keys=True), flush=True)
        elif not args.json:
            _print_row(row)
        if show:
            show(len(rows))
    summary = summarise(rows)
    if args.jsonl:
        print(json.dumps({"summary": rounded(summary)}, sort_keys=True))
    elif args.json:
        print(
            json.dumps({"files": [rounded(r) for r in rows], "summary": rounded(summary)}, indent=2)
        )
    else:
        print(
            f"{summary['files']} files: {summary['present']} present, {summary['absent']} "
            f"absent, {summary['errors']} unreadable"
        )
    return int(summary["exit_code"])


def _print_row(row: dict[str, Any]) -> None:
    verdict = "error" if row["error"] else ("present" if row["detected"] else "absent")
    extra = row["error"] or (f"id {row['id']}" if row["id"] else "")
    if row["ber"] is not None:
        extra = f"BER {row['ber']:.4f}, p-value {row['p_value']:.3g}" + (
            f", {extra}" if extra else ""
        )
    print(f"{row['path']}: {verdict}" + (f" ({extra})" if extra else ""), flush=True)


def _verify_one(args: argparse.Namespace) -> int:
    """One file against one mark: a mesh with no meshwm grid is absent, not an error."""
    from meshwm.detect import decide
    from meshwm.errors import GridError
    from meshwm.mesh.io import read_mesh
    from meshwm.message.mark import load_mark
    from meshwm.watermark import extract

    expected = load_mark(args.mark, size=args.mark_size)
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    report: dict[str, Any] = {"input": str(args.input), "fpr": args.fpr, "threshold": args.fpr}
    try:
        result = extract(
            vertices,
            faces,
            key=args.key,
            mark_size=args.mark_size,
            expected=expected,
            params=options.watermark_params(args),
            max_faces=args.max_faces,
        )
    except GridError as exc:
        # A mesh we can read but that holds no meshwm grid carries no mark: absent, not error.
        report.update(
            detected=False,
            ber=None,
            correlation=None,
            bits=args.mark_size**2,
            p_value=1.0,
            reason=str(exc),
        )
    else:
        r = result.report
        report.update(
            detected=decide(r, fpr=args.fpr).detected,
            hypotheses=r["hypotheses"],
            threshold=args.fpr / r["hypotheses"],
            ber=r["ber"],
            correlation=r["correlation"],
            bits=r["bits"],
            p_value=r["p_value"],
            seconds=round(r["seconds"], 3),
        )
    if args.json:
        print(json.dumps(rounded(report), indent=2, sort_keys=True))
    else:
        verdict = "present" if report["detected"] else "absent"
        detail = (
            f"BER {report['ber']:.4f}, p-value {report['p_value']:.3g}"
            if report["ber"] is not None
            else report["reason"]
        )
        print(f"{args.input}: mark {verdict} ({detail})")
    return EXIT_OK if report["detected"] else EXIT_ABSENT
