"""Null study of issue 14: the informed reader on meshes that carry no registered copy.

A registry holding every development mesh (two marked copies each, for two recipients) is
built first (or ``--registry`` reuses one).  Then every development mesh, *unmarked*, as given
and re-tessellated (quadric simplification to 50 %, midpoint and Loop subdivision, isotropic
remeshing), is posed once against its candidate assets (``meshwm.watermark.trace.Tracer``) and
traced with ``--keys`` random keys (SHA-256 of a seed, never the registry's key) and with the
registry's own key.  Each marked copy is also traced with ``--wrong-keys`` random keys.  A
trial is a detection when ``trace`` identifies any copy at FPR 1e-6 (every candidate × pose ×
copy counted).  Prints a table (trials, detections, the largest z of the best copy, the
smallest p-value × hypotheses) and exits 1 if anything is detected.

    python scripts/null_informed.py [--keys 200] [--wrong-keys 50] [--jobs 2] [--out FILE]
        [--reuse DIR]

``--reuse DIR`` keeps the registry (``DIR/registry.db``) and the marked copies (``DIR/*.npy``)
there: built on the first run, taken as they are on the next.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_informed import IDS, KEY, MAX_FACES, embed_mesh  # type: ignore[import-not-found]
from check_keep import DEV, MESHES  # type: ignore[import-not-found]

from meshwm.apps.registry import Registry
from meshwm.attacks import apply_attack
from meshwm.mesh.io import read_mesh
from meshwm.watermark.trace import Tracer

FPR = 1e-6
WRONG = "wrong keys"
VARIANTS = {
    "as given": None,
    "simplify 50 %": ("simplify", {"keep_fraction": 0.5}),
    "midpoint": ("subdivide_midpoint", {}),
    "Loop": ("subdivide_loop", {}),
    "isotropic": ("remesh_isotropic", {}),
}


def _key(*parts: object) -> str:
    return hashlib.sha256("/".join(map(str, parts)).encode()).hexdigest()


def _trials(tracer: Tracer, keys: list[str]) -> dict[str, Any]:
    detected = 0
    z_max = -np.inf
    ph_min = np.inf
    for key in keys:
        found = tracer.trace(key=key, fpr=FPR)
        detected += bool(found.detected)
        r = found.report
        z_max = max(z_max, float(r.get("z", -np.inf) or -np.inf))
        ph_min = min(ph_min, float(r["p_value"]) * int(r["hypotheses"]))
    return {"trials": len(keys), "detected": detected, "z_max": z_max, "ph_min": ph_min}


def run_case(task: tuple[str, str, str, str, int, int]) -> dict[str, Any] | None:
    """One mesh × one case (an unmarked variant, or the marked copy under wrong keys)."""
    name, label, db, scratch, n_keys, n_wrong = task
    v, f = read_mesh(MESHES / f"{name}.ply")
    t0 = time.perf_counter()
    with Registry.open(db, create=False) as registry:
        if label == WRONG:
            marked_path = Path(scratch) / f"{name}.npy"
            if not marked_path.exists():
                return None
            tracer = Tracer(np.load(marked_path), f, registry, max_faces=MAX_FACES)
            keys = [_key("wrong", name, i) for i in range(n_wrong)]
        else:
            attack = VARIANTS[label]
            vv, ff = (
                (v, f) if attack is None else apply_attack(attack[0], v, f, seed=1, **attack[1])
            )
            tracer = Tracer(vv, ff, registry, max_faces=MAX_FACES)
            keys = [_key("null", name, label, i) for i in range(n_keys)] + [KEY]
        row = _trials(tracer, keys)
    case = "marked, wrong keys" if label == WRONG else f"unmarked, {label}"
    return {"mesh": name, "case": case, **row, "seconds": time.perf_counter() - t0}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=DEV)
    parser.add_argument("--keys", type=int, default=200)
    parser.add_argument("--wrong-keys", type=int, default=50)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--reuse", type=Path, help="a folder an earlier run built")
    args = parser.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as temporary:
        scratch = str(args.reuse) if args.reuse else temporary
        os.makedirs(scratch, exist_ok=True)
        db = os.path.join(scratch, "registry.db")
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            built = []
            if not os.path.exists(db):
                built = list(pool.map(embed_mesh, [(m, db, scratch) for m in args.meshes]))
            errors = [r for r in built if "error" in r]
            tasks = [
                (m, label, db, scratch, args.keys, args.wrong_keys)
                for m in args.meshes
                for label in [*VARIANTS, WRONG]
            ]
            rows = []
            for future in as_completed([pool.submit(run_case, t) for t in tasks]):
                row = future.result()
                if row is None:
                    continue
                rows.append(row)
                print(
                    f"{row['mesh']}, {row['case']}: {row['detected']}/{row['trials']} detected, "
                    f"largest z {row['z_max']:.2f} ({row['seconds']:.0f} s)",
                    file=sys.stderr,
                    flush=True,
                )
        order = {(m, c): i for i, (m, c) in enumerate((t[0], t[1]) for t in tasks)}
        rows.sort(key=lambda r: order[(r["mesh"], r["case"].split(", ", 1)[-1])])
        with Registry.open(db, create=False) as registry:
            held = (len(registry.assets()), len(registry.copies()))
    lines = [
        "| mesh | case | trials | detected | largest z | smallest p × hypotheses |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['mesh']} | {r['case']} | {r['trials']} | {r['detected']} | "
            f"{r['z_max']:.2f} | {r['ph_min']:.3g} |"
        )
    trials = sum(r["trials"] for r in rows)
    detected = sum(r["detected"] for r in rows)
    lines.append(
        f"\n{trials} traces against a registry of {held[0]} assets and {held[1]} copies "
        f"(ids {', '.join(i.hex() for i in IDS)}): {detected} detections "
        f"({time.perf_counter() - t0:.0f} s, FPR {FPR:g})"
    )
    lines += [f"{r['mesh']}: {r['error']}" for r in errors]
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 1 if detected else 0


if __name__ == "__main__":
    sys.exit(main())
