"""``meshwm trace``: which registered asset and copy a file is.  Exit 0 found, 1 not, 2 error.

Every mesh of the file is read blind first (any id, as ``verify --any-id``); an id that reads is
looked up in the registry.  A mesh that reads nothing blind (decimated, subdivided, remeshed,
cropped) goes to the informed reader (:mod:`meshwm.watermark.trace`), which poses it against
the registered assets and tests each copy's signature.  The report names the reader used.
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

NAME = "trace"
HELP = "which registered asset and copy a file is (exit 0 found, 1 not found, 2 error)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm trace`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Read every mesh of the file blind (any id), then, for a mesh that reads nothing, "
            "with the informed reader: the registered assets whose shape is nearest, the "
            "mesh posed against each one's reference, its surface sampled there and each "
            "copy's signature tested. Reports the asset, the copy (id, recipient), the "
            "p-value against --fpr over every hypothesis tried, and the reader used. The "
            "informed reader: meshwm docs informed."
        ),
    )
    parser.add_argument("input", type=Path, help="the received mesh file")
    parser.add_argument(
        "--registry", required=True, metavar="DB", help="the registry: a file or a PostgreSQL URL"
    )
    options.add_fpr_option(parser)
    parser.add_argument(
        "--candidates",
        type=options.positive_int,
        default=10,
        help="registered assets tried, nearest shape first (10)",
    )
    parser.add_argument(
        "--informed-only", action="store_true", help="skip the blind readers (quicker)"
    )
    options.add_watermark_options(parser, size=False)
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Trace ``args.input``; the exit code says whether a copy was found."""
    from meshwm.apps.progress import Status
    from meshwm.apps.registry import Registry
    from meshwm.mesh.asset import read_asset

    key = options.key_of(args)
    params = options.watermark_params(args)
    with Registry.open(args.registry, create=False) as registry, Status(sys.stderr) as status:
        status.stage(f"reading {args.input}")
        asset = read_asset(args.input, max_faces=args.max_faces)
        rows = _trace_asset(asset, registry, key, params, args, status.stage)
    found = [r for r in rows if r["detected"]]
    report = {"input": str(args.input), "detected": bool(found), "fpr": args.fpr, "meshes": rows}
    if args.json:
        out = rounded(report)
        out["meshes"] = [rounded(r) for r in rows]
        print(json.dumps(out, indent=2, sort_keys=True, default=str))
    else:
        for row in rows:
            print(_line(row))
    return EXIT_OK if found else EXIT_ABSENT


def _trace_asset(
    asset: Any,
    registry: Any,
    key: str | bytes,
    params: Any,
    args: argparse.Namespace,
    progress: Any,
) -> list[dict[str, Any]]:
    from meshwm.apps.tracing import trace_mesh
    from meshwm.watermark.assets import verify_asset

    blind: list[dict[str, Any]] = []
    if not args.informed_only:
        blind = verify_asset(
            asset,
            key=key,
            any_id=True,
            fpr=args.fpr,
            params=params,
            max_faces=args.max_faces,
            progress=progress,
        )
    rows = []
    for k, mesh in enumerate(asset.meshes):
        row: dict[str, Any] = {"name": mesh.name}
        read = blind[k] if blind else None
        if read is not None and read["detected"] and read.get("id"):
            copies = _nearest_asset(
                registry, [c for c in registry.copies() if c.payload == read["id"]], asset, k
            )
            row.update(
                detected=True,
                reader=read.get("reader", "blind"),
                id=read["id"],
                hypotheses=read.get("hypotheses"),
                copies=[_copy(registry, c) for c in copies],
            )
            if not copies:
                row["note"] = "the id reads blind but no copy with it is registered"
        elif mesh.reason is not None:
            row.update(detected=False, reason=mesh.reason)
        else:
            progress(f"informed reading of {mesh.name}")
            traced = trace_mesh(
                asset.vertices(k),
                mesh.faces,
                key=key,
                registry=registry,
                fpr=args.fpr,
                candidates=args.candidates,
                max_faces=args.max_faces,
            )
            row.update(traced)
            if traced["detected"]:
                row["copies"] = [
                    _copy(registry, c)
                    for c in registry.copies(traced["asset_id"])
                    if c.id == traced["copy_id"]
                ]
        rows.append(row)
    return rows


def _nearest_asset(registry: Any, copies: list[Any], asset: Any, k: int) -> list[Any]:
    """The copies (of one id) that belong to the asset whose shape is nearest the mesh's: an
    id may have gone to one recipient with several assets."""
    owners = sorted({c.asset_id for c in copies})
    if len(owners) <= 1:
        return copies
    from meshwm.watermark.trace import nearest_assets

    (nearest,) = nearest_assets(
        registry, asset.vertices(k), asset.meshes[k].faces, among=owners, count=1
    )
    return [c for c in copies if c.asset_id == nearest]


def _copy(registry: Any, copy: Any) -> dict[str, Any]:
    return {
        "asset_id": copy.asset_id,
        "asset": registry.asset(copy.asset_id).name,
        "copy_id": copy.id,
        "id": copy.payload,
        "recipient": copy.recipient,
        "output": copy.output_name,
        "created": copy.created,
    }


def _through(row: dict[str, Any]) -> str:
    """How the informed reader matched the received mesh to the asset, for the report line."""
    if row.get("correspondence") == "vertices":
        return ", read vertex by vertex: the received mesh is the asset's own mesh"
    return ""


def _line(row: dict[str, Any]) -> str:
    name = row["name"]
    if not row["detected"] and row.get("asset_detected"):
        return (
            f"{name}: asset {row['asset']!r} (#{row['asset_id']}): {row['note']} (best copy "
            f"#{row['copy_id']}, z {row['versus_z']:.1f} against the runner-up)"
        )
    if not row["detected"]:
        why = row.get("reason") or "no registered copy found"
        p = row.get("p_value")
        tail = f" (best p-value {p:.3g} over {row.get('hypotheses')} hypotheses)" if p else ""
        return f"{name}: NOT traced: {why}{tail}"
    copies = row.get("copies") or []
    who = "; ".join(
        f"asset {c['asset']!r} (#{c['asset_id']}), copy #{c['copy_id']} for "
        f"{c['recipient'] or 'no recipient recorded'}"
        for c in copies
    )
    reader = row.get("reader", "blind")
    what = f"id {row['id']}" if not str(row["id"]).startswith("mark:") else "a mark"
    if reader == "informed":
        return (
            f"{name}: {what}, {who}; informed reader (registry{_through(row)}), p-value "
            f"{row['p_value']:.3g} over {row['hypotheses']} hypotheses, z {row['z']:.1f}"
        )
    return f"{name}: {what} read blind ({reader}); {who or row.get('note', '')}"
