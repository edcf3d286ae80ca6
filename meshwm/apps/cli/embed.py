"""``meshwm embed``: mark every mesh of a file with a 64-bit id (or a mark) under a key.

By default the file is kept whole (:mod:`meshwm.mesh.asset`): the same format, every byte but
the moved vertex positions, every mesh of a scene or multi-object file marked
(:func:`meshwm.watermark.assets.embed_asset`).  ``--grid`` writes the paper's grid mesh
instead (one mesh, bare geometry).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK, rounded

if TYPE_CHECKING:  # pragma: no cover - for type checkers only
    from numpy.typing import NDArray

    from meshwm.apps.progress import Status
    from meshwm.apps.tracing import MarkedMesh
    from meshwm.params import WatermarkParams

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "embed"
HELP = "mark every mesh of a file with a 64-bit id (or a mark) under a key"


def mesh_ident(text: str) -> tuple[str, bytes]:
    """``NAME=ID``: the id of one mesh (``--mesh-id``); ID as ``--id`` reads it."""
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"expected NAME=ID, got {text!r}")
    return name, options.ident(value)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm embed`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Embed a 64-bit id (--id) or a mark (default: the bundled 32×32 logo) under the key "
            "into every mesh of the file and write it whole: same format, same vertices, faces, "
            "polygons, UVs, normals, colours, materials, properties, dtype and scene graph; "
            "only vertex positions move. --grid writes the paper's semi-regular N×N grid mesh "
            "instead. What is kept per format, and the id and key rules: meshwm docs assets."
        ),
    )
    parser.add_argument("input", type=Path, help="input mesh file")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="output file (its suffix: the format)"
    )
    parser.add_argument("--mark", type=Path, help="mark image (PNG, BMP, ...), thresholded")
    parser.add_argument(
        "--id",
        type=options.ident,
        dest="ident",
        metavar="ID",
        help="embed a 64-bit id instead of a mark: 0x and up to 16 hex digits, anything else "
        "is text of up to 8 bytes (CRC-32 and Reed-Solomon protected)",
    )
    parser.add_argument(
        "--mesh-id",
        type=mesh_ident,
        action="append",
        default=[],
        metavar="NAME=ID",
        help="the id of the mesh called NAME (repeat for several); the others get --id",
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
        help="write the geometry image's N×N grid mesh instead of the input's meshes (--size)",
    )
    options.add_watermark_options(parser, size=True)
    parser.add_argument(
        "--registry",
        metavar="DB",
        help="record the asset and this copy (never the key) in a registry: a file (SQLite, "
        "made if missing) or a PostgreSQL URL; trace and the informed reader use it",
    )
    parser.add_argument(
        "--recipient", metavar="TEXT", help="who receives this copy (recorded with --registry)"
    )
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
    from meshwm.apps.progress import Status
    from meshwm.message.mark import default_mark, load_mark

    key = options.key_of(args)
    params = options.watermark_params(args)
    if args.ident is not None and args.mark:
        raise ValueError("--id and --mark exclude each other: embed a mark or an id")
    if args.mesh_id and args.mark:
        raise ValueError("--mesh-id and --mark exclude each other: embed marks or ids")
    mark = None
    if args.ident is None and not args.mesh_id:
        mark = (
            load_mark(args.mark, size=args.mark_size) if args.mark else default_mark(args.mark_size)
        )
    if args.recipient is not None and not args.registry:
        raise ValueError("--recipient is recorded in a registry: give --registry too")
    registry = None
    if args.registry:
        from meshwm.apps.registry import Registry

        registry = Registry.open(args.registry)  # a bad registry fails before any work
    started = time.perf_counter()
    try:
        with Status(sys.stderr) as status:
            if args.grid:
                report, marked = _embed_grid(args, key, params, mark, status)
            else:
                report, marked = _embed_kept(args, key, params, mark, status)
            if registry is not None:
                status.stage(f"recording in {registry.name}")
                report["registry"] = _record(args, registry, key, params, marked, report)
    finally:
        if registry is not None:
            registry.close()
    report["seconds"] = round(time.perf_counter() - started, 3)
    if args.json:
        print(json.dumps(_json_ready(report), indent=2, sort_keys=True))
    elif args.grid:
        _print_report(report)
    else:
        _print_kept(report)
    return EXIT_OK


def _json_ready(report: dict[str, Any]) -> dict[str, Any]:
    out = rounded(report)
    if "meshes" in out:
        out["meshes"] = [rounded(row) for row in out["meshes"]]
    return out


def _embed_grid(
    args: argparse.Namespace,
    key: str | bytes,
    params: WatermarkParams,
    mark: NDArray | None,
    status: Status,
) -> tuple[dict[str, Any], list[MarkedMesh]]:
    """The paper's output: one mesh read bare, remeshed to the N×N grid, marked."""
    from meshwm.mesh.io import check_output, read_mesh, write_mesh
    from meshwm.watermark import embed

    if args.mesh_id:
        raise ValueError("--mesh-id marks the meshes of a file; --grid writes one grid mesh")
    check_output(args.output, overwrite_input=args.input, force=args.force)
    status.stage(f"reading {args.input}")
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    status.stage(f"remeshing and marking at N={params.size}")
    result = embed(
        vertices,
        faces,
        mark,
        key=key,
        params=params,
        max_faces=args.max_faces,
        distances=not args.no_distance,
        ident=args.ident,
        grid=True,
    )
    status.stage(f"writing {args.output}")
    write_mesh(
        args.output, result.vertices, result.faces, overwrite_input=args.input, force=args.force
    )
    from meshwm.apps.tracing import MarkedMesh, mark_payload

    payload = mark_payload(mark, args.ident)
    one = MarkedMesh(
        args.input.name,
        vertices,
        faces,
        result.vertices,
        result.faces,
        payload,
        int(result.report["n"]),
    )
    return {"input": str(args.input), "output": str(args.output), **result.report}, [one]


def _embed_kept(
    args: argparse.Namespace,
    key: str | bytes,
    params: WatermarkParams,
    mark: NDArray | None,
    status: Status,
) -> tuple[dict[str, Any], list[MarkedMesh]]:
    """Every mesh of the file marked in place; the file written whole."""
    from dataclasses import asdict

    from meshwm.mesh.asset import check_asset_output, missing_sidecars, read_asset, write_asset
    from meshwm.watermark.assets import embed_asset

    check_asset_output(args.output, overwrite_input=args.input, force=args.force)
    status.stage(f"reading {args.input}")
    asset = read_asset(args.input, max_faces=args.max_faces)
    marked = embed_asset(
        asset,
        mark,
        key=key,
        ident=args.ident,
        idents=dict(args.mesh_id),
        params=params,
        max_faces=args.max_faces,
        distances=not args.no_distance,
        progress=status.stage,
    )
    status.stage(f"writing {args.output}")
    written = write_asset(args.output, marked.asset, overwrite_input=args.input, force=args.force)
    notes = []
    same_format = args.output.suffix.lower() == asset.suffix
    missing = missing_sidecars(asset, args.output) if same_format else []
    if missing:
        notes.append(
            f"{args.output} refers to {', '.join(missing)}, next to the input but not next to "
            "the output: copy them along"
        )
    report: dict[str, Any] = {
        "input": str(args.input),
        "output": str(args.output),
        "mode": "kept",
        "format": written.suffix,
        "meshes": marked.meshes,
        "kept": {
            "before": asdict(asset.summary),
            "after": asdict(written.summary),
            "changes": written.summary.changes_from(asset.summary),
        },
        "notes": notes,
    }
    if len(marked.meshes) == 1:  # one mesh: its figures at the top, as for a bare mesh
        report.update({k: v for k, v in marked.meshes[0].items() if k != "name"})
    return report, _marked_meshes(args, asset, marked, mark)


def _marked_meshes(
    args: argparse.Namespace, asset: Any, marked: Any, mark: NDArray | None
) -> list[MarkedMesh]:
    """The marked meshes of a kept embed, before and after, for the registry."""
    from meshwm.apps.tracing import MarkedMesh, mark_payload

    out = []
    several = len(asset.meshes) > 1
    for k, row in enumerate(marked.meshes):
        if not row.get("marked"):
            continue
        mesh = asset.meshes[k]
        name = f"{args.input.name}#{mesh.name}" if several else args.input.name
        payload = row["id"] if "id" in row else mark_payload(mark)
        out.append(
            MarkedMesh(
                name,
                asset.vertices(k),
                mesh.faces,
                marked.asset.vertices(k),
                mesh.faces,
                payload,
                int(row["n"]),
            )
        )
    return out


def _record(
    args: argparse.Namespace,
    registry: Any,
    key: str | bytes,
    params: WatermarkParams,
    marked: list[MarkedMesh],
    report: dict[str, Any],
) -> list[dict[str, Any]]:
    """Record the copy; if that fails, the output is removed (no unrecorded copy goes out).
    A copy whose payload an earlier copy of the same asset carries is recorded, with a
    warning (``same_payload_as``)."""
    import hashlib

    from meshwm.apps.tracing import record_copies

    try:
        digest = hashlib.sha256(args.output.read_bytes()).hexdigest()
        recorded = record_copies(
            registry,
            marked,
            key=key,
            recipient=args.recipient,
            output_name=args.output.name,
            output_sha256=digest,
            params={"profile": params.profile, "mode": report.get("mode", "kept")},
            max_faces=args.max_faces,
        )
    except BaseException:
        if args.output.resolve() != args.input.resolve():  # never the input (--force)
            args.output.unlink(missing_ok=True)
        raise
    rows: list[dict[str, Any]] = []
    for mesh, (asset_id, copy_id) in zip(marked, recorded, strict=True):
        row: dict[str, Any] = {"asset_id": asset_id, "copy_id": copy_id}
        # The same payload under the same key is the same mark: trace could not say which
        # recipient's copy turned up.  (The key is not stored, so the registry cannot tell
        # whether the keys differ: say so and let the user decide.)
        earlier = [c for c in registry.find_copies(asset_id, mesh.payload) if c.id < copy_id]
        if earlier:
            first = earlier[0]
            row["same_payload_as"] = first.id
            who = f" for {first.recipient}" if first.recipient else ""
            print(
                f"meshwm: warning: copy #{copy_id} of asset #{asset_id} carries the same payload "
                f"as copy #{first.id}{who}; under the same key trace cannot tell them apart "
                "(give each recipient its own --id)",
                file=sys.stderr,
            )
        rows.append(row)
    return rows


def _count(n: int, word: str) -> str:
    """``n`` and ``word``, plural unless ``n`` is 1 (a word ending in "sh" takes "es")."""
    plural = word if n == 1 else (word + "es" if word.endswith("sh") else word + "s")
    return f"{n} {plural}"


def _summary_line(summary: dict[str, Any]) -> str:
    parts = [_count(summary["vertices"], "vertex").replace("vertexs", "vertices")]
    parts.append(_count(summary["faces"], "face"))
    names = {"polygons": "polygon", "uvs": "UV", "normals": "normal", "colors": "colour"}
    names["materials"] = "material"
    for key, word in names.items():
        if summary[key]:
            parts.append(_count(summary[key], word))
    parts.append(_count(summary["meshes"], "mesh"))
    return ", ".join(parts) + f"; {summary['dtype']}"


def _mesh_line(row: dict[str, Any]) -> str:
    from meshwm.message.payload import format_id

    what = f"id {format_id(row['id'])}" if "id" in row else f"{row['mark_size']}² mark"
    if not row["marked"]:
        return f"  {row['name']}: NOT marked ({row['reason']})"
    text = (
        f"  {row['name']}: {what} marked; {row['vertices']} vertices kept, N={row['n']}, "
        f"PSNR {row['psnr']:.1f} dB"
    )
    if "mrms_rel" in row:
        text += (
            f", MRMS {100 * row['mrms_rel']:.4f}%, Hausdorff {100 * row['hausdorff_rel']:.3f}% "
            "of the bbox diagonal"
        )
    pieces = row.get("pieces")
    if pieces:  # each big piece marked alone
        text += f"; marked piece by piece: {pieces['marked']} of its {pieces['of']} pieces"
        text += " big enough for the payload carry it each"
        if pieces["smaller"]:
            text += f", {_count(pieces['smaller'], 'smaller piece')} unchanged"
        for reason in row.get("pieces_unmarked", []):
            text += f"; not marked: {reason}"
    parts, detached = row.get("components_passed_through", 0), row.get("faces_detached", 0)
    if parts:  # the surface map carries the mark in the largest part alone
        text += f"; {_count(parts, 'smaller part')} kept off the surface map (moved by the "
        text += "radial mark only)"
    if detached:
        text += f"; {_count(detached, 'face')} on non-manifold edges detached"
    if row.get("read_ber"):  # accepted with a few bits wrong (at most 2 %)
        text += f"; its surface map reads back {row['read_ber']:.1%} of its bits wrong"
        text += ", which its code corrects" if "id" in row else ""
    return text


def _print_kept(report: dict[str, Any]) -> None:
    meshes = report["meshes"]
    marked = sum(1 for row in meshes if row["marked"])
    lines = [
        f"{report['input']} -> {report['output']}: {marked} of {len(meshes)} "
        f"mesh{'es' if len(meshes) != 1 else ''} marked",
        *(_mesh_line(row) for row in meshes),
    ]
    kept = report["kept"]
    converted = Path(report["input"]).suffix.lower() != report["format"]
    if kept["changes"]:
        lines.append(
            f"  file : converted to {report['format']}; differs: {'; '.join(kept['changes'])}"
        )
    else:
        done = f"converted to {report['format']}" if converted else "kept whole"
        lines.append(f"  file : {done}: {_summary_line(kept['after'])}")
    lines += [f"  note : {note}" for note in report["notes"]]
    lines.append(f"  time : {report['seconds']:.2f} s")
    print("\n".join(lines))


def _print_report(report: dict[str, Any]) -> None:
    from meshwm.message.payload import format_id

    lines = [
        f"{report['input']} -> {report['output']}",
        (
            f"  id   : {format_id(report['id'])} ({report['used_bits']} code bits "
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
