"""``meshwm attack``: apply one attack of the registry to a mesh.

An STL file stores every triangle's corners apart (a soup): attacked as it is, a noise or
smoothing attack would move the copies of a vertex apart and crack the surface.  The corners
are welded first, by exact position (:func:`meshwm.attacks.seams.weld_by_position`), then
attacked and written back, so the output is as closed as the input.

Every attack parameter of the registry is an option ``--NAME V``: the options are the union over
all attacks (so they can come in any order and ``--help`` lists them); :func:`run` refuses those
that the chosen ``--kind`` does not take.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "attack"
HELP = "apply one attack (smoothing, noise, cropping, simplification, ...) to a mesh"


def _param_kinds() -> dict[str, list[str]]:
    """Every attack parameter name -> the attacks that take it."""
    from meshwm.attacks import ATTACK_PARAMS

    kinds: dict[str, list[str]] = {}
    for kind, params in ATTACK_PARAMS.items():
        for p in params:
            kinds.setdefault(p.name, []).append(kind)
    return kinds


def _epilog() -> str:
    """Each attack's parameters, their defaults and allowed values."""
    from meshwm.attacks import ATTACK_PARAMS, ATTACKS

    lines = ["parameters per kind (default; allowed):"]
    for kind in sorted(ATTACKS):
        text = "; ".join(
            f"--{p.name} {'random' if p.default is None else p.default} ({p.allowed})"
            for p in ATTACK_PARAMS[kind]
        )
        lines.append(f"  {kind}: {text or 'none'}")
    lines.append("meshwm docs attacks defines every attack and its units.")
    return "\n".join(lines)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm attack`` to ``subparsers``; its ``--kind`` choices come from the registry."""
    from meshwm.attacks import ATTACKS

    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "Apply one seeded, deterministic attack from the registry (meshwm.attacks.ATTACKS) "
            "and write the result. gim_* attacks are the paper's, on the geometry image, and "
            "need a grid mesh (embed --grid). An STL input is welded first (corners at the same "
            "position merged), attacked, and written back."
        ),
        epilog=_epilog(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("input", type=Path, help="input mesh file")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output mesh file")
    parser.add_argument(
        "--kind",
        required=True,
        choices=sorted(ATTACKS),
        metavar="KIND",
        help=f"the attack: {', '.join(sorted(ATTACKS))}",
    )
    parser.add_argument(
        "--seed", type=options.seed, default=0, help="random seed, a number >= 0 (0)"
    )
    for name, kinds in sorted(_param_kinds().items()):
        flags = [f"--{name}"]
        if "_" in name:
            flags.append(f"--{name.replace('_', '-')}")
        parser.add_argument(
            *flags,
            dest=f"attack_{name}",
            metavar="V",
            help=f"parameter of {', '.join(kinds)}",
        )
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument(
        "--force", action="store_true", help="allow the output to overwrite the input file"
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Attack ``args.input`` and write ``args.output``; print the report."""
    from meshwm.attacks import ATTACK_PARAMS, apply_attack
    from meshwm.mesh.io import check_output, read_mesh, write_mesh

    started = time.perf_counter()
    spec = {p.name: p for p in ATTACK_PARAMS[args.kind]}
    given = {
        name: getattr(args, f"attack_{name}")
        for name in _param_kinds()
        if getattr(args, f"attack_{name}") is not None
    }
    wrong = [name for name in given if name not in spec]
    if wrong:
        valid = ", ".join(f"--{name}" for name in spec) or "none"
        raise ValueError(
            f"--kind {args.kind} takes no {', '.join(f'--{name}' for name in wrong)}; "
            f"its parameters: {valid}"
        )
    attack_options = {name: spec[name].parse(text, args.kind) for name, text in given.items()}
    check_output(args.output, overwrite_input=args.input, force=args.force)
    vertices, faces = read_mesh(args.input)
    welded = None
    if args.input.suffix.lower() == ".stl":
        from meshwm.attacks.seams import weld_by_position

        corners = len(vertices)
        vertices, faces = weld_by_position(vertices, faces)
        welded = {"corners": corners, "vertices": len(vertices)}
    out_v, out_f = apply_attack(args.kind, vertices, faces, seed=args.seed, **attack_options)
    write_mesh(args.output, out_v, out_f, overwrite_input=args.input, force=args.force)
    report = {
        "input": str(args.input),
        "output": str(args.output),
        "kind": args.kind,
        "params": {name: attack_options.get(name, p.default) for name, p in spec.items()},
        "seed": args.seed,
        "vertices_in": len(vertices),
        "faces_in": len(faces),
        "vertices_out": len(out_v),
        "faces_out": len(out_f),
        "seconds": round(time.perf_counter() - started, 3),
    }
    if welded is not None:
        report["welded"] = welded
    if args.json:
        print(json.dumps(report, indent=2, sort_keys=True))
    else:
        if welded is not None:
            print(
                f"{report['input']}: an STL soup; its {welded['corners']} corners were welded "
                f"into {welded['vertices']} vertices (exact positions) before the attack"
            )
        params = ", ".join(f"{k}={v}" for k, v in report["params"].items())
        print(
            f"{report['input']} -> {report['output']}: {args.kind}({params}), seed {args.seed}: "
            f"{report['vertices_in']} vertices, {report['faces_in']} faces -> "
            f"{report['vertices_out']} vertices, {report['faces_out']} faces"
        )
    return EXIT_OK
