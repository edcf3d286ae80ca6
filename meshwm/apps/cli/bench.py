"""``meshwm bench``: the paper's Tables 2-4 beside ours, mesh attacks and strength curves."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path
from typing import Any

from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "bench"
HELP = "the paper's Tables 2-4 side by side with ours, mesh attacks and strength curves"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm bench`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Mark the bundled models at the paper's three PSNRs and run its attacks (paper "
            "table, extracted marks, curves of corr2 against PSNR), then run the mesh attacks "
            "on every mesh of --meshes. Writes Markdown, JSON and PNG files into --out; "
            "meshwm docs bench explains them."
        ),
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="the packaged spot mesh only, fewer strengths and attacks (CI, under 3 minutes)",
    )
    parser.add_argument(
        "--out", type=Path, default=Path("meshwm-bench"), help="output folder (meshwm-bench)"
    )
    parser.add_argument(
        "--meshes",
        type=Path,
        metavar="DIR",
        help="folder of meshes for the mesh-attack table (the bundled ones; not with --quick)",
    )
    parser.add_argument(
        "--profiles",
        default="paper,robust",
        help="comma-separated watermark profiles to run (paper,robust)",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument(
        "--force", action="store_true", help="allow overwriting the files of an earlier run"
    )
    parser.set_defaults(run=run)
    return parser


def _profiles(text: str) -> list[str]:
    """``--profiles``: a comma-separated subset of :data:`meshwm.profiles.PROFILES`, no repeats."""
    from meshwm.profiles import PROFILES

    profiles = [p.strip() for p in text.split(",") if p.strip()]
    bad = [p for p in profiles if p not in PROFILES]
    if not profiles or bad or len(set(profiles)) != len(profiles):
        raise ValueError(
            f"--profiles: expected a comma-separated subset of {','.join(PROFILES)}, got {text!r}"
        )
    return profiles


def run(args: argparse.Namespace) -> int:
    """Run the benchmark into ``args.out``; print its summary."""
    from meshwm.apps.bench import BENCH_FILES, ProgressBar, check_out, run_bench

    profiles = _profiles(args.profiles)
    if args.quick and args.meshes is not None:
        raise ValueError("--meshes: --quick runs the packaged spot mesh only")
    check_out(args.out, force=args.force)  # before any work
    words = ["meshwm", "bench", *(["--quick"] if args.quick else [])]
    if args.meshes is not None:
        words += ["--meshes", str(args.meshes)]
    words += ["--profiles", ",".join(profiles), "--out", str(args.out)]
    progress = ProgressBar(sys.stderr) if sys.stderr.isatty() and not args.json else None
    result = run_bench(
        quick=args.quick,
        out=args.out,
        meshes=args.meshes,
        profiles=profiles,
        progress=progress,
        force=args.force,
        command=shlex.join(words),
    )
    summary = {
        "out": str(args.out),
        "files": sorted(BENCH_FILES),
        "profiles_run": result["settings"]["profiles_run"],
        "profiles_skipped": result["settings"]["profiles_skipped"],
        "paper_table": result["paper_table"]["summary"],
        "mesh_attacks": result["mesh_attacks"]["summary"],
        "seconds": result["seconds"]["total"],
    }
    if args.json:
        print(json.dumps(summary, indent=2, sort_keys=True))
    else:
        _print_summary(args.out, summary)
    return EXIT_OK


def _print_summary(out: Path, summary: dict[str, Any]) -> None:
    lines = [f"meshwm bench -> {out} ({summary['seconds']:.0f} s)"]
    for profile, why in summary["profiles_skipped"].items():
        lines.append(f"  {profile}: skipped, {why}")
    for profile, tables in summary["paper_table"].items():
        won = ", ".join(f"{t['table']} {t['won']}/{t['rows']}" for t in tables.values())
        lines.append(f"  {profile}: paper rows won (corr2 >= the paper's): {won}")
    for profile, s in summary["mesh_attacks"].items():
        lines.append(
            f"  {profile}: required mesh attacks with corr2 >= 0.9: {s['passed']}/{s['required']}"
            f"; MRMS <= 0.02 % on every mesh: {'yes' if s['mrms_ok'] else 'no'}"
        )
    lines.append(f"  tables: {out / 'paper_table.md'}, {out / 'mesh_attacks.md'}")
    print("\n".join(lines))
