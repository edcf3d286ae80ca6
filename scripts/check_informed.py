"""What the registry and the informed reader survive: the must-show table of issue 14.

Phase 1, for every mesh (in parallel processes, all writing one SQLite registry at once): embed
two 64-bit ids with the input's mesh kept (``meshwm.embed``), for two recipients, and record
both copies (``meshwm.apps.tracing.record_copies``: the asset's descriptor and reference, each
copy's sealed signature).  MRMS and Hausdorff of the first copy against the input (MeshLab).

Phase 2, for every mesh and attack on the first copy: read as ``meshwm trace`` does, blind
first (``meshwm.watermark.Decoder``, every reader, FPR 1e-6), then the informed reader against
the whole registry (``meshwm.watermark.trace.Tracer``: nearest assets by shape, pose, offsets,
each copy's signature; every candidate × pose × copy counted).  A cell is ``ok·b`` (the id
read blind), ``ok·i`` (traced by the informed reader to the right copy through the pose: the
right asset, id and recipient, p-value × hypotheses under 1e-6) or ``ok·v`` (the same, vertex by
vertex: the received mesh is the asset's own), else the informed reader's z (or what went
wrong).  The wrong-key row traces the unattacked copy with another key.

    python scripts/check_informed.py [--meshes spot fandisk ...] [--jobs 2] [--out FILE]
        [--no-blind]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_keep import DEV, MESHES, attacks  # type: ignore[import-not-found]

from meshwm.apps.registry import Registry
from meshwm.apps.tracing import MarkedMesh, record_copies
from meshwm.attacks import apply_attack
from meshwm.detect import decide
from meshwm.mesh.io import read_mesh
from meshwm.watermark import Decoder, embed
from meshwm.watermark.trace import Tracer

IDS = (bytes.fromhex("5ca1ab1e0ddba11f"), bytes.fromhex("0b5e55ed0ff1ce42"))
RECIPIENTS = ("vendor-a", "vendor-b")
KEY = "studio-key-2026"
FPR = 1e-6
MAX_FACES = 10**7

Attack = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _a(name: str, **options: Any) -> Attack:
    return lambda v, f: apply_attack(name, v, f, seed=7, **options)


def _then(first: Attack, second: Attack) -> Attack:
    return lambda v, f: second(*first(v, f))


def required() -> dict[str, Attack]:
    """Issue 14's attacks, then issue 13's (every one of those is required too)."""
    out: dict[str, Attack] = {
        "simplify 50 %": _a("simplify", keep_fraction=0.5),
        "simplify 30 %": _a("simplify", keep_fraction=0.3),
        "midpoint subdivision": _a("subdivide_midpoint"),
        "Loop subdivision": _a("subdivide_loop"),
        "isotropic remesh ×3": _a("remesh_isotropic", iterations=3),
        "crop 30 %": _a("crop", fraction=0.3),
        "similarity, simplify 50 %": _then(_a("similarity"), _a("simplify", keep_fraction=0.5)),
    }
    out.update({k: v for k, v in attacks(beyond=False).items() if v is not None})
    return out


def reported() -> dict[str, Attack]:
    """Issue 14's rows to report, then the rows issue 13 asks to report beyond its own."""
    out: dict[str, Attack] = {
        "simplify 10 %": _a("simplify", keep_fraction=0.1),
        "screened Poisson": _a("poisson", depth=8),
    }
    beyond, own = attacks(beyond=True), attacks(beyond=False)
    for name, attack in beyond.items():
        if attack is not None and name not in own and name != "simplify 50 %":
            out[name] = attack
    return out


def embed_mesh(task: tuple[str, str, str]) -> dict[str, Any]:
    """Phase 1: two copies of one mesh, recorded; the first copy saved for phase 2."""
    name, db, scratch = task
    v, f = read_mesh(MESHES / f"{name}.ply")
    row: dict[str, Any] = {"mesh": name, "V": len(v)}
    t0 = time.perf_counter()
    copies = []
    for k, ident in enumerate(IDS):
        try:
            marked = embed(v, f, key=KEY, ident=ident, distances=k == 0, max_faces=MAX_FACES)
        except Exception as exc:
            return {**row, "error": f"{type(exc).__name__}: {exc}"}
        copies.append(marked.vertices)
        if k == 0:
            row.update(mrms=marked.report["mrms_rel"], hausdorff=marked.report["hausdorff_rel"])
            row["n"] = marked.report["n"]
        with Registry.open(db) as registry:
            record_copies(
                registry,
                [MarkedMesh(name, v, f, marked.vertices, f, ident.hex(), marked.report["n"])],
                key=KEY,
                recipient=RECIPIENTS[k],
                output_name=f"{name}_{k}.ply",
                output_sha256="0" * 64,
                params={"profile": "robust", "mode": "kept"},
                max_faces=MAX_FACES,
            )
    row["embed_s"] = time.perf_counter() - t0
    np.save(Path(scratch) / f"{name}.npy", copies[0])
    return row


def _blind(v: np.ndarray, f: np.ndarray) -> bool:
    try:
        got = Decoder(v, f, max_faces=MAX_FACES).extract_id(key=KEY, expected=IDS[0])
    except Exception:
        return False
    verdict = decide(got.report, fpr=FPR, found_id=got.id, expected_id=IDS[0].hex())
    return bool(verdict.detected and got.id == IDS[0].hex())


def _informed(
    v: np.ndarray, f: np.ndarray, registry: Any, name: str, key: str = KEY
) -> tuple[bool, str]:
    try:
        traced = Tracer(v, f, registry, max_faces=MAX_FACES).trace(key=key, fpr=FPR)
    except Exception as exc:
        return False, f"error: {type(exc).__name__}"
    r = traced.report
    ok = (
        traced.detected
        and r.get("asset") == name
        and r["id"] == IDS[0].hex()
        and r.get("recipient") == RECIPIENTS[0]
    )
    if ok:  # i: through the pose; v: vertex by vertex (the received mesh is the asset's own)
        return True, "ok·v" if r.get("correspondence") == "vertices" else "ok·i"
    return False, f"z {r.get('z', 0.0):.1f}"


def read_mesh_attacks(task: tuple[str, str, str, bool]) -> dict[str, Any]:
    """Phase 2: every attack on one mesh's first copy, read blind then informed."""
    name, db, scratch, blind = task
    _, f = read_mesh(MESHES / f"{name}.ply")
    marked = np.load(Path(scratch) / f"{name}.npy")
    cells: dict[str, str] = {}
    seconds: dict[str, float] = {}
    with Registry.open(db, create=False) as registry:
        ok, _ = _informed(marked, f, registry, name, key="another key")
        wrong = "DETECTED" if ok else "no"
        for label, attack in {**required(), **reported()}.items():
            t0 = time.perf_counter()
            try:
                av, af = attack(marked, f)
            except Exception as exc:
                cells[label] = f"attack failed: {type(exc).__name__}"
                continue
            if blind and _blind(av, af):
                cells[label] = "ok·b"
            else:
                cells[label] = _informed(av, af, registry, name)[1]
            seconds[label] = time.perf_counter() - t0
            print(f"{name}: {label}: {cells[label]} ({seconds[label]:.1f} s)", file=sys.stderr)
    return {"mesh": name, "cells": cells, "wrong key": wrong, "read_s": seconds}


def table(rows: list[dict[str, Any]], reads: dict[str, dict[str, Any]]) -> str:
    good = [r for r in rows if "error" not in r]
    lines = ["| | " + " | ".join(r["mesh"] for r in good) + " |", "|" + "---|" * (len(good) + 1)]
    for key, fmt in [
        ("V", "{}"),
        ("n", "{}"),
        ("mrms", "{:.4%}"),
        ("hausdorff", "{:.3%}"),
        ("embed_s", "{:.1f}"),
    ]:
        lines.append(f"| {key} | " + " | ".join(fmt.format(r[key]) for r in good) + " |")
    lines.append("| wrong key | " + " | ".join(reads[r["mesh"]]["wrong key"] for r in good) + " |")
    for label in [*required(), *reported()]:
        cells = [reads[r["mesh"]]["cells"].get(label, "-") for r in good]
        count = sum(c.startswith("ok") for c in cells)
        tag = " (report)" if label in reported() else ""
        lines.append(f"| {label}{tag} ({count}/{len(good)}) | " + " | ".join(cells) + " |")
    for r in rows:
        if "error" in r:
            lines.append(f"\n{r['mesh']}: {r['error']}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=DEV)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--no-blind", action="store_true", help="informed reader only")
    args = parser.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        db = os.path.join(scratch, "registry.db")
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            rows = list(pool.map(embed_mesh, [(m, db, scratch) for m in args.meshes]))
            with Registry.open(db, create=False) as registry:
                recorded = len(registry.copies())
            done = [r["mesh"] for r in rows if "error" not in r]
            tasks = [(m, db, scratch, not args.no_blind) for m in done]
            reads = {r["mesh"]: r for r in pool.map(read_mesh_attacks, tasks)}
    text = table(rows, reads)
    text += (
        f"\n\n{recorded} copies recorded by {args.jobs} processes at once (expected "
        f"{2 * len(done)}); {time.perf_counter() - t0:.0f} s"
    )
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
