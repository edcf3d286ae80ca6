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
from meshwm._malloc import keep_freed_memory
from meshwm._validate import DEFAULT_MAX_FACES, check_square_pow2
from meshwm.apps.batch import Check, expand_paths, progress_bar, run_dask, run_local, summarise
from meshwm.attacks.library import ATTACK_PARAMS, ATTACKS, apply_attack
from meshwm.detect import decide
from meshwm.errors import GridError
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.io import READ_SUFFIXES, WRITE_SUFFIXES, check_output, read_mesh, write_mesh
from meshwm.message.mark import MARK_SIZE_RANGE, default_mark, load_mark, save_mark
from meshwm.message.payload import parse_id
from meshwm.metrics import surface_distance
from meshwm.params import CHANNELS, DEFAULT_STEP, PROFILES, WatermarkParams
from meshwm.watermark import embed, extract, extract_id

__all__ = ["main"]

EXIT_OK = 0
EXIT_ABSENT = 1
EXIT_ERROR = 2


class _UsageError(Exception):
    """A bad command line; carries argparse's message."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line and exit code 2 (not a usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(message)


def _whole_number(text: str, low: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"expected a number >= {low}, got {value}")
    return value


def _positive_int(text: str) -> int:
    return _whole_number(text, 1)


def _size(text: str) -> int:
    try:
        return check_square_pow2(_positive_int(text), name="--size")
    except (TypeError, ValueError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _mark_size(text: str) -> int:
    value = _positive_int(text)
    low, high = MARK_SIZE_RANGE
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"expected a mark size in {low}..{high}, got {value}")
    return value


def _channels(text: str) -> tuple[str, ...]:
    names = tuple(t.strip() for t in text.split(",") if t.strip())
    bad = [n for n in names if n not in CHANNELS]
    if not names or bad:
        raise argparse.ArgumentTypeError(
            f"expected a comma-separated subset of {','.join(CHANNELS)}, got {text!r}"
        )
    return names


def _probability(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a probability in (0, 1), got {text}")
    return value


def _ident(text: str) -> bytes:
    try:
        return parse_id(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _real(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return value


def _key(text: str) -> str:
    if not text:
        raise argparse.ArgumentTypeError("the key must not be empty")
    return text


def _add_watermark_options(p: argparse.ArgumentParser, *, size: bool) -> None:
    """The public parameters; extraction must be given the ones embedding used."""
    defaults = WatermarkParams()
    p.add_argument("--key", type=_key, required=True, help="the secret key (any string)")
    p.add_argument(
        "--profile",
        choices=PROFILES,
        default=defaults.profile,
        help=(
            "embedding scheme: 'robust' survives smoothing, quantisation and cropping; "
            f"'paper' is the paper's scheme, for comparison ({defaults.profile})"
        ),
    )
    if size:
        p.add_argument(
            "--size",
            type=_size,
            default=defaults.size,
            help=f"geometry-image size N, a power of two 64..2048 ({defaults.size})",
        )
    p.add_argument(
        "--channels",
        type=_channels,
        default=defaults.channels,
        help=f"canonical axes that carry the mark ({','.join(defaults.channels)})",
    )
    p.add_argument(
        "--step",
        type=_real,
        default=None,
        help=(
            "quantisation step: for 'paper' relative to the model's RMS radius "
            f"({DEFAULT_STEP['paper']}), for 'robust' to the local sample spacing "
            f"({DEFAULT_STEP['robust']}); robust extraction does not need it"
        ),
    )
    p.add_argument(
        "--arnold-iterations",
        type=int,
        default=defaults.arnold_iterations,
        help=f"Arnold scrambling iterations of the mark ({defaults.arnold_iterations})",
    )
    p.add_argument(
        "--max-faces",
        type=_positive_int,
        default=DEFAULT_MAX_FACES,
        help=f"refuse inputs with more faces ({DEFAULT_MAX_FACES})",
    )


def _params(args: argparse.Namespace) -> WatermarkParams:
    return WatermarkParams(
        profile=args.profile,
        size=getattr(args, "size", WatermarkParams().size),
        channels=args.channels,
        step=args.step,
        arnold_iterations=args.arnold_iterations,
    )


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

    emb = sub.add_parser(
        "embed",
        help="watermark a mesh with a mark image and a key",
        description=(
            "Remesh to a geometry image, embed the mark (default: the bundled 32×32 logo) "
            "under the key, and write the marked mesh."
        ),
    )
    emb.add_argument("input", type=Path, help="input mesh file")
    emb.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    emb.add_argument("--mark", type=Path, help="mark image (PNG, BMP, ...), thresholded")
    emb.add_argument(
        "--id",
        type=_ident,
        dest="ident",
        metavar="TEXT|HEX",
        help="embed a 64-bit id instead of a mark: up to 16 hex digits or 8 bytes of text "
        "(CRC-32 and Reed-Solomon protected)",
    )
    emb.add_argument(
        "--mark-size", type=_mark_size, default=32, help="resample the mark to this side (32)"
    )
    _add_watermark_options(emb, size=True)
    emb.add_argument("--json", action="store_true", help="print the report as JSON")
    emb.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    emb.add_argument(
        "--no-distance", action="store_true", help="skip the MeshLab distance measurements"
    )
    emb.set_defaults(run=_run_embed)

    ext = sub.add_parser(
        "extract",
        help="read the mark from a mesh (blind: the mesh and the key only)",
        description="Find the grid in the mesh, read the mark and write it as a PNG.",
    )
    ext.add_argument("input", type=Path, help="received mesh file")
    ext.add_argument("-o", "--output", type=Path, help="mark image to write (.png)")
    ext.add_argument(
        "--mark-size", type=_mark_size, default=32, help="side of the square mark (32)"
    )
    ext.add_argument("--mark", type=Path, help="the original mark, to report BER and corr2")
    _add_watermark_options(ext, size=False)
    ext.add_argument("--json", action="store_true", help="print the report as JSON")
    ext.set_defaults(run=_run_extract)

    ver = sub.add_parser(
        "verify",
        help="decide whether a mesh carries a mark (exit 0 present, 1 absent, 2 error)",
        description=(
            "Extract and compare with the expected mark: present when the bit agreement is "
            "significant: p-value below --fpr divided by the number of hypotheses the decoder "
            "tried (binomial test, fair-coin null, Bonferroni)."
        ),
    )
    ver.add_argument(
        "input", type=Path, nargs="+", help="mesh files, folders (searched recursively) or globs"
    )
    what = ver.add_mutually_exclusive_group(required=True)
    what.add_argument("--mark", type=Path, help="the expected mark image")
    what.add_argument("--id", type=_ident, dest="ident", metavar="TEXT|HEX", help="the expected id")
    what.add_argument(
        "--any-id", action="store_true", help="present when any valid id decodes (reports it)"
    )
    ver.add_argument(
        "--mark-size", type=_mark_size, default=32, help="side of the square mark (32)"
    )
    ver.add_argument(
        "--fpr",
        type=_probability,
        default=1e-6,
        help="false-positive probability allowed, over all hypotheses tried (1e-6)",
    )
    ver.add_argument(
        "--jobs", type=_positive_int, default=1, help="files checked in parallel processes (1)"
    )
    ver.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://host:8786); needs pip install 'meshwm[dask]'",
    )
    ver.add_argument(
        "--jsonl", action="store_true", help="one JSON line per file, then a summary line"
    )
    _add_watermark_options(ver, size=False)
    ver.add_argument("--json", action="store_true", help="print the result as JSON")
    ver.set_defaults(run=_run_verify)

    _add_attack_parser(sub)
    _add_render_parser(sub)

    demo = sub.add_parser(
        "demo",
        help="embed the logo into a bundled mesh, attack it, extract, and show the marks",
        description=(
            "Embeds the default logo into the bundled spot mesh (N=256), runs a few attacks, "
            "extracts, prints a table and writes the meshes and a PNG of the marks."
        ),
    )
    demo.add_argument(
        "--out", type=Path, default=Path("meshwm-demo"), help="output folder (meshwm-demo)"
    )
    demo.set_defaults(run=_run_demo)

    bench = sub.add_parser(
        "bench",
        help="the paper's Tables 2-4 side by side with ours, mesh attacks and strength curves",
        description=(
            "Mark the bundled models at the paper's three PSNRs and run its attacks (paper "
            "table, extracted marks, curves of corr2 against PSNR), then run the mesh attacks "
            "on every mesh of --meshes. Writes Markdown, JSON and PNG files into --out; "
            "docs/bench.md explains them."
        ),
    )
    bench.add_argument(
        "--quick",
        action="store_true",
        help="the packaged spot mesh only, fewer strengths and attacks (CI, under 3 minutes)",
    )
    bench.add_argument(
        "--out", type=Path, default=Path("meshwm-bench"), help="output folder (meshwm-bench)"
    )
    bench.add_argument(
        "--meshes",
        type=Path,
        metavar="DIR",
        help="folder of meshes for the mesh-attack table (the bundled ones; not with --quick)",
    )
    bench.add_argument(
        "--profiles",
        default="paper,robust",
        help="comma-separated watermark profiles to run (paper,robust)",
    )
    bench.add_argument("--json", action="store_true", help="print the summary as JSON")
    bench.add_argument(
        "--force", action="store_true", help="allow overwriting the files of an earlier run"
    )
    bench.set_defaults(run=_run_bench)
    return parser


def _round(report: dict) -> dict:
    """Floats to 6 significant digits (not decimals: p-values and thresholds are tiny)."""
    return {k: float(f"{v:.6g}") if isinstance(v, float) else v for k, v in report.items()}


def _run_embed(args: argparse.Namespace) -> int:
    check_output(args.output, overwrite_input=args.input, force=args.force)
    params = _params(args)
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
    )
    write_mesh(
        args.output, result.vertices, result.faces, overwrite_input=args.input, force=args.force
    )
    report = {"input": str(args.input), "output": str(args.output), **result.report}
    report["seconds"] = round(report["seconds"], 3)
    if args.json:
        print(json.dumps(_round(report), indent=2, sort_keys=True))
    else:
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
        if "mrms_rel" in report:
            lines.append(
                f"  mark distortion: MRMS {100 * report['mrms_rel']:.4f}% of the bbox diagonal"
            )
            lines.append(
                f"  output vs input: Hausdorff {100 * report['hausdorff_rel']:.3f}%, "
                f"RMS {100 * report['rms_rel']:.4f}%"
            )
        lines.append(f"  time : {report['seconds']:.2f} s")
        print("\n".join(lines))
    return EXIT_OK


def _check_png(
    path: Path, inputs: Sequence[Path | None], *, what: str, force: bool | None = None
) -> None:
    """Refuse, before any work, a PNG output that is misnamed, homeless or an input.

    ``force=None``: the command has no ``--force``; the input is never overwritten.
    """
    if path.suffix.lower() != ".png":
        raise ValueError(f"{path}: the {what} is written as PNG; give the file a .png suffix")
    if not path.resolve().parent.is_dir():
        raise ValueError(f"{path}: folder {path.parent} does not exist")
    for source in inputs:
        if source is not None and not force and path.exists() and source.exists():
            if path.samefile(source):
                hint = "" if force is None else "; use --force"
                raise ValueError(f"{path}: would overwrite the input{hint}")


def _run_extract(args: argparse.Namespace) -> int:
    if args.output is None and not args.json:
        raise ValueError("give -o MARK.png to write the mark, or --json to print the report")
    if args.output is not None:
        _check_png(args.output, [args.input], what="mark")
    expected = load_mark(args.mark, size=args.mark_size) if args.mark else None
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    result = extract(
        vertices,
        faces,
        key=args.key,
        mark_size=args.mark_size,
        expected=expected,
        params=_params(args),
        max_faces=args.max_faces,
    )
    report = {"input": str(args.input), "output": None, **result.report}
    if args.output is not None:
        save_mark(args.output, result.mark)
        report["output"] = str(args.output)
    if args.json:
        # The id payload, if the mesh carries one (None otherwise: the CRC decides).
        found = extract_id(
            vertices, faces, key=args.key, params=_params(args), max_faces=args.max_faces
        )
        report["id"] = found.id
        print(json.dumps(_round(report), indent=2, sort_keys=True))
    else:
        line = f"{args.input}: {args.mark_size}×{args.mark_size} mark -> {args.output}"
        if expected is not None:
            line += f" (BER {report['ber']:.4f}, corr2 {report['correlation']:.4f})"
        print(line)
    return EXIT_OK


def _run_verify(args: argparse.Namespace) -> int:
    if len(args.input) == 1 and args.mark and not args.jsonl and not args.scheduler:
        args.input = args.input[0]
        return _verify_one(args)
    return _verify_batch(args)


def _verify_batch(args: argparse.Namespace) -> int:
    """Many files (or an id): one row per file, a summary, exit 0 / 1 / 2 (meshwm.apps.batch)."""
    check = Check(
        key=args.key,
        params=_params(args),
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
            print(json.dumps(_round(row), sort_keys=True), flush=True)
        elif not args.json:
            verdict = "error" if row["error"] else ("present" if row["detected"] else "absent")
            extra = row["error"] or (f"id {row['id']}" if row["id"] else "")
            if row["ber"] is not None:
                extra = f"BER {row['ber']:.4f}, p-value {row['p_value']:.3g}" + (
                    f", {extra}" if extra else ""
                )
            print(f"{row['path']}: {verdict}" + (f" ({extra})" if extra else ""), flush=True)
        if show:
            show(len(rows))
    summary = summarise(rows)
    if args.jsonl:
        print(json.dumps({"summary": _round(summary)}, sort_keys=True))
    elif args.json:
        print(
            json.dumps({"files": [_round(r) for r in rows], "summary": _round(summary)}, indent=2)
        )
    else:
        print(
            f"{summary['files']} files: {summary['present']} present, {summary['absent']} "
            f"absent, {summary['errors']} unreadable"
        )
    return int(summary["exit_code"])


def _verify_one(args: argparse.Namespace) -> int:
    expected = load_mark(args.mark, size=args.mark_size)
    vertices, faces = read_mesh(args.input, max_faces=args.max_faces)
    report: dict = {"input": str(args.input), "fpr": args.fpr, "threshold": args.fpr}
    try:
        result = extract(
            vertices,
            faces,
            key=args.key,
            mark_size=args.mark_size,
            expected=expected,
            params=_params(args),
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
        print(json.dumps(_round(report), indent=2, sort_keys=True))
    else:
        verdict = "present" if report["detected"] else "absent"
        detail = (
            f"BER {report['ber']:.4f}, p-value {report['p_value']:.3g}"
            if report["ber"] is not None
            else report["reason"]
        )
        print(f"{args.input}: mark {verdict} ({detail})")
    return EXIT_OK if report["detected"] else EXIT_ABSENT


def _seed(text: str) -> int:
    return _whole_number(text, 0)


def _attack_param_kinds() -> dict[str, list[str]]:
    """Every attack parameter name -> the attacks that take it."""
    kinds: dict[str, list[str]] = {}
    for kind, params in ATTACK_PARAMS.items():
        for p in params:
            kinds.setdefault(p.name, []).append(kind)
    return kinds


def _add_attack_parser(sub: argparse._SubParsersAction) -> None:
    """``meshwm attack``: every attack parameter of the registry is an option ``--NAME V``.

    The options are the union over all attacks (so they can come in any order and ``--help``
    lists them); :func:`_run_attack` refuses those that the chosen ``--kind`` does not take.
    """
    lines = ["parameters per kind (default; allowed):"]
    for kind in sorted(ATTACKS):
        params = ATTACK_PARAMS[kind]
        text = "; ".join(
            f"--{p.name} {'random' if p.default is None else p.default} ({p.allowed})"
            for p in params
        )
        lines.append(f"  {kind}: {text or 'none'}")
    lines.append("docs/attacks.md defines every attack and its units.")
    att = sub.add_parser(
        "attack",
        help="apply one attack (smoothing, noise, cropping, simplification, ...) to a mesh",
        description=(
            "Apply one seeded, deterministic attack from the registry (meshwm.attacks.ATTACKS) "
            "and write the result. gim_* attacks are the paper's, on the geometry image, and "
            "need a mesh written by meshwm."
        ),
        epilog="\n".join(lines),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    att.add_argument("input", type=Path, help="input mesh file")
    att.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    att.add_argument(
        "--kind",
        required=True,
        choices=sorted(ATTACKS),
        metavar="KIND",
        help=f"the attack: {', '.join(sorted(ATTACKS))}",
    )
    att.add_argument("--seed", type=_seed, default=0, help="random seed, a number >= 0 (0)")
    for name, kinds in sorted(_attack_param_kinds().items()):
        flags = [f"--{name}"]
        if "_" in name:
            flags.append(f"--{name.replace('_', '-')}")
        att.add_argument(
            *flags,
            dest=f"attack_{name}",
            metavar="V",
            help=f"parameter of {', '.join(kinds)}",
        )
    att.add_argument("--json", action="store_true", help="print the report as JSON")
    att.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    att.set_defaults(run=_run_attack)


def _run_attack(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    spec = {p.name: p for p in ATTACK_PARAMS[args.kind]}
    given = {
        name: getattr(args, f"attack_{name}")
        for name in _attack_param_kinds()
        if getattr(args, f"attack_{name}") is not None
    }
    wrong = [name for name in given if name not in spec]
    if wrong:
        valid = ", ".join(f"--{name}" for name in spec) or "none"
        raise ValueError(
            f"--kind {args.kind} takes no {', '.join(f'--{name}' for name in wrong)}; "
            f"its parameters: {valid}"
        )
    options = {name: spec[name].parse(text, args.kind) for name, text in given.items()}
    check_output(args.output, overwrite_input=args.input, force=args.force)
    vertices, faces = read_mesh(args.input)
    out_v, out_f = apply_attack(args.kind, vertices, faces, seed=args.seed, **options)
    write_mesh(args.output, out_v, out_f, overwrite_input=args.input, force=args.force)
    report = {
        "input": str(args.input),
        "output": str(args.output),
        "kind": args.kind,
        "params": {name: options.get(name, p.default) for name, p in spec.items()},
        "seed": args.seed,
        "vertices_in": len(vertices),
        "faces_in": len(faces),
        "vertices_out": len(out_v),
        "faces_out": len(out_f),
        "seconds": round(time.perf_counter() - started, 3),
    }
    if args.json:
        print(json.dumps(report, indent=2, sort_keys=True))
    else:
        params = ", ".join(f"{k}={v}" for k, v in report["params"].items())
        print(
            f"{report['input']} -> {report['output']}: {args.kind}({params}), seed {args.seed}: "
            f"{report['vertices_in']} vertices, {report['faces_in']} faces -> "
            f"{report['vertices_out']} vertices, {report['faces_out']} faces"
        )
    return EXIT_OK


def _add_render_parser(sub: argparse._SubParsersAction) -> None:
    """``meshwm render``: shaded views of a mesh, or a heat map of its distance to another."""
    # meshwm.apps.render's VIEWS_RANGE and SIZE_RANGE, not imported: matplotlib would then load on
    # every command (tests/test_render.py checks that they agree).
    views_range, size_range = (1, 12), (100, 4000)

    def bounded(name: str, low: int, high: int):  # an argparse type: text -> int
        def parse(text: str) -> int:
            value = _whole_number(text, low)
            if value > high:
                raise argparse.ArgumentTypeError(f"expected {name} in {low}..{high}, got {value}")
            return value

        return parse

    ren = sub.add_parser(
        "render",
        help="draw shaded views of a mesh as a PNG, or a heat map of its distance to another",
        description=(
            "Draw a row of flat-shaded orthographic views of the mesh. With --compare, colour "
            "it by the distance from each of its vertices to the surface of OTHER, in % of "
            "OTHER's bounding-box diagonal. docs/render.md describes the pictures."
        ),
    )
    ren.add_argument("input", type=Path, help="mesh file to draw")
    ren.add_argument("-o", "--output", type=Path, required=True, help="picture to write (.png)")
    ren.add_argument(
        "--compare", type=Path, metavar="OTHER", help="reference mesh: draw the distance to it"
    )
    ren.add_argument(
        "--views",
        type=bounded("a number of views", *views_range),
        default=3,
        metavar="N",
        help=f"number of views side by side, {views_range[0]}..{views_range[1]} (3)",
    )
    ren.add_argument(
        "--size",
        type=bounded("a width", *size_range),
        default=900,
        metavar="PX",
        help=f"picture width in pixels, {size_range[0]}..{size_range[1]} (900)",
    )
    ren.add_argument("--json", action="store_true", help="print the report as JSON")
    ren.add_argument(
        "--force", action="store_true", help="allow the output to overwrite an input file"
    )
    ren.set_defaults(run=_run_render)


def _run_render(args: argparse.Namespace) -> int:
    from meshwm._atomic import write_atomic
    from meshwm.apps.render import render_comparison, render_views

    started = time.perf_counter()
    out = args.output
    _check_png(out, [args.input, args.compare], what="picture", force=args.force)
    vertices, faces = read_mesh(args.input)
    report: dict = {"input": str(args.input), "output": str(out)}
    if args.compare is None:
        png = render_views(vertices, faces, views=args.views, size=args.size, title=args.input.name)
    else:
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
        print(json.dumps(_round(report), indent=2, sort_keys=True))
    else:
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
    return EXIT_OK


def _run_demo(args: argparse.Namespace) -> int:
    from meshwm.apps.demo import run_demo

    run_demo(args.out)
    return EXIT_OK


def _run_bench(args: argparse.Namespace) -> int:
    import shlex

    from meshwm.apps.bench import BENCH_FILES, ProgressBar, check_out, run_bench
    from meshwm.params import PROFILES

    profiles = [p.strip() for p in args.profiles.split(",") if p.strip()]
    bad = [p for p in profiles if p not in PROFILES]
    if not profiles or bad or len(set(profiles)) != len(profiles):
        raise ValueError(
            f"--profiles: expected a comma-separated subset of {','.join(PROFILES)}, "
            f"got {args.profiles!r}"
        )
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
        return EXIT_OK
    lines = [f"meshwm bench -> {args.out} ({summary['seconds']:.0f} s)"]
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
    lines.append(f"  tables: {args.out / 'paper_table.md'}, {args.out / 'mesh_attacks.md'}")
    print("\n".join(lines))
    return EXIT_OK


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
    keep_freed_memory()  # big temporaries reuse memory instead of faulting pages in
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
