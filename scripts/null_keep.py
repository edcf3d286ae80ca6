"""Null study of issue 13: the surface reader on meshes that do not carry the mark.

For every development mesh, unmarked: the mesh as it is, after 100 flips of flat edges, noise
(0.1 %), 10-bit quantisation and a random similarity, each read once
(``meshwm.watermark.Decoder``: every reader, or only ``--readers``) and decoded with ``--keys``
random keys, each checked for a random 64-bit id exactly as
``meshwm verify --id`` decides (p-value below 1e-6 over every hypothesis counted, and the id read
back equal to the one expected), and for any valid id at all (``--any-id``: a Reed-Solomon
decode whose CRC-32 matches).  Then each mesh is marked with an id (its mesh kept) and read with
``--wrong-keys`` other keys.  Keys and ids come from SHA-256 of a seed, never from the right
key.  Prints a table (detections, valid ids, smallest p-value x hypotheses) and exits 1 if
anything is detected.  With ``--logo`` the expected payload is the bundled 32×32 logo, decided as
``meshwm verify --mark`` decides (p-value of the bits' agreement below 1e-6 over every
hypothesis counted), its column "drawn" counts the reads whose image was taken as a drawing
(``"chosen_by": "drawing"``: noise should never look like one), and the marked meshes carry
the logo (a mesh that cannot is a row with the refusal).  ``--odd`` reads shapes unlike the
development meshes instead (:data:`ODD`: a triangle soup the surface reader cannot map, a
sphere and a torus with no pose of their own, a flat sheet, many small components); a shape
the embedder refuses is a row with the refusal.  ``--seams`` reads each mesh after its UV
seams were split and then moved (0.1 % noise, MeshLab's Laplacian, 3 steps) or quantised to
10 bits, instead of the attacks above, and the marked mesh after the split and the noise: the
cases where the surface reader also offers the mesh with its borders zipped
(:mod:`meshwm.mesh.zip`).

    python scripts/null_keep.py [--keys 350] [--wrong-keys 50] [--first-key 0]
        [--readers radial ...] [--logo] [--odd] [--seams] [--jobs 2] [--out FILE]

(``--readers 'surface (mirrored)'``: the surface reader's images of the mirror image alone,
counted alone.)
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from meshwm.attacks import apply_attack
from meshwm.detect import decide
from meshwm.mesh.io import read_mesh
from meshwm.message.mark import default_mark
from meshwm.readers import reader_names
from meshwm.watermark import Decoder, embed

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
DEV = [p.stem for p in sorted(MESHES.glob("*.ply"))]
FPR = 1e-6


def _soup() -> trimesh.Trimesh:
    rng = np.random.default_rng(1)
    corners = rng.random((1500, 1, 3)) + 0.01 * rng.standard_normal((1500, 3, 3))
    return trimesh.Trimesh(corners.reshape(-1, 3), np.arange(4500).reshape(-1, 3), process=False)


def _components() -> trimesh.Trimesh:
    rng = np.random.default_rng(2)
    parts = [
        trimesh.creation.icosphere(2, radius=0.1).apply_translation(c) for c in rng.random((20, 3))
    ]
    return trimesh.util.concatenate(parts)


#: Shapes unlike the development meshes (``--odd``), each at least 2,000 vertices.
ODD = {
    "soup": _soup,  # 1,500 triangles sharing no vertex: no surface to map
    "icosphere": lambda: trimesh.creation.icosphere(5),  # 10,242 vertices, every pose alike
    "torus": lambda: trimesh.creation.torus(1.0, 0.3, major_sections=128, minor_sections=64),
    "sheet": lambda: trimesh.creation.box().subdivide_to_size(0.035).apply_scale([1, 1, 0.001]),
    "components": _components,  # 20 spheres of 162 vertices
}


def load(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A development mesh by its name, or an :data:`ODD` shape."""
    if name in ODD:
        m = ODD[name]()
        return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)
    return read_mesh(MESHES / f"{name}.ply")


def _derived(*parts: object) -> bytes:
    return hashlib.sha256("/".join(map(str, parts)).encode()).digest()


def _trial(decoder: Decoder, key: str, ident: bytes) -> dict[str, Any]:
    got = decoder.extract_id(key=key, expected=ident)
    verdict = decide(got.report, fpr=FPR, found_id=got.id, expected_id=ident.hex())
    return {
        "detected": bool(verdict.detected),
        "valid": got.id is not None,
        "p_h": verdict.p_value * verdict.hypotheses,
    }


def _trial_logo(decoder: Decoder, key: str, ident: bytes) -> dict[str, Any]:
    got = decoder.extract(key=key, expected=default_mark(32))
    verdict = decide(got.report, fpr=FPR)
    return {
        "detected": bool(verdict.detected),
        "valid": got.report["chosen_by"] == "drawing",
        "p_h": verdict.p_value * verdict.hypotheses,
    }


def _split_then(
    v: np.ndarray, f: np.ndarray, attack: str, **options: Any
) -> tuple[np.ndarray, np.ndarray]:
    """The mesh with seams split (as a UV export splits them), then ``attack``."""
    sv, sf = apply_attack("split_seams", v, f, seed=1)
    return apply_attack(attack, sv, sf, seed=1, **options)


def run_mesh(
    task: tuple[str, int, int, tuple[str, ...] | None, int, bool, bool],
) -> list[dict[str, Any]]:
    """Every trial on one mesh (a worker); keys and ids numbered from ``first``."""
    name, keys, wrong, readers, first, logo, seams = task
    trial = _trial_logo if logo else _trial
    v, f = load(name)
    if seams:
        variants = {
            "seams split, noise 0.1 %": _split_then(v, f, "noise", amplitude=0.001),
            "seams split, MeshLab Laplacian 3": _split_then(v, f, "meshlab_laplacian"),
            "seams split, 10-bit": _split_then(v, f, "quantize", bits=10),
        }
    else:
        variants = {
            "as given": (v, f),
            "100 flips": apply_attack("flip_edges", v, f, seed=1, count=100),
            "noise 0.1 %": apply_attack("noise", v, f, seed=1, amplitude=0.001),
            "10-bit": apply_attack("quantize", v, f, seed=1, bits=10),
            "similarity": apply_attack("similarity", v, f, seed=1),
        }
    rows = []
    for label, (vv, ff) in variants.items():
        t0 = time.perf_counter()
        try:
            decoder = Decoder(vv, ff, readers=readers)
        except Exception as exc:  # a row of the table
            rows.append({"mesh": name, "case": label, "error": f"{type(exc).__name__}: {exc}"})
            continue
        trials = [
            trial(decoder, _derived("key", name, label, i).hex(), _derived("id", i)[:8])
            for i in range(first, first + keys)
        ]
        rows.append(_summary(name, f"unmarked, {label}", trials, t0))
    t0 = time.perf_counter()
    ident = _derived("marked", name)[:8]
    try:
        right = _derived("right", name).hex()
        if logo:
            marked = embed(v, f, default_mark(32), key=right, distances=False)
        else:
            marked = embed(v, f, key=right, ident=ident, distances=False)
    except Exception as exc:
        rows.append({"mesh": name, "case": "marked", "error": f"{type(exc).__name__}: {exc}"})
        return rows
    mv, mf = marked.vertices, marked.faces
    if seams:
        mv, mf = _split_then(mv, mf, "noise", amplitude=0.001)
    decoder = Decoder(mv, mf, readers=readers)
    trials = [
        trial(decoder, _derived("wrong", name, j).hex(), ident) for j in range(first, first + wrong)
    ]
    case = "marked, seams split, noise 0.1 %, wrong keys" if seams else "marked, wrong keys"
    rows.append(_summary(name, case, trials, t0))
    return rows


def _summary(name: str, case: str, trials: list[dict[str, Any]], t0: float) -> dict[str, Any]:
    return {
        "mesh": name,
        "case": case,
        "trials": len(trials),
        "detected": sum(t["detected"] for t in trials),
        "valid": sum(t["valid"] for t in trials),
        "min_p_h": min(t["p_h"] for t in trials),
        "seconds": time.perf_counter() - t0,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=DEV)
    parser.add_argument("--keys", type=int, default=350)
    parser.add_argument("--wrong-keys", type=int, default=50)
    parser.add_argument("--readers", nargs="+", help="only these readers (default: all)")
    parser.add_argument(
        "--first-key",
        type=int,
        default=0,
        help="number keys (and wrong keys) from here: runs with disjoint ranges add up",
    )
    parser.add_argument("--logo", action="store_true", help="the 32×32 logo instead of ids")
    parser.add_argument("--odd", action="store_true", help="the odd shapes, not the dev meshes")
    parser.add_argument("--seams", action="store_true", help="seams split, then moved")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    t0 = time.perf_counter()
    readers = tuple(args.readers) if args.readers else None
    if min(args.keys, args.wrong_keys) < 1 or args.first_key < 0:
        parser.error("--keys and --wrong-keys must be >= 1, --first-key >= 0")
    if readers is not None and set(readers) - set(reader_names()):
        parser.error(f"--readers: valid: {', '.join(map(repr, reader_names()))}")
    if args.odd and args.seams:
        parser.error("--seams splits the development meshes' seams: give --odd or --seams")
    if args.odd:
        if args.meshes != DEV:
            parser.error("--odd reads its own shapes: give --odd or --meshes, not both")
        args.meshes = list(ODD)
    unknown = [n for n in args.meshes if n not in ODD and not (MESHES / f"{n}.ply").is_file()]
    if unknown:
        parser.error(f"no such mesh: {', '.join(unknown)} (not in {MESHES})")
    if args.out is not None and not args.out.parent.is_dir():
        parser.error(f"--out: no such directory: {args.out.parent}")
    tasks = [
        (name, args.keys, args.wrong_keys, readers, args.first_key, args.logo, args.seams)
        for name in args.meshes
    ]
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = [row for result in pool.map(run_mesh, tasks) for row in result]
    counted = "drawn" if args.logo else "valid ids"
    lines = [
        f"| mesh | case | trials | detected | {counted} | smallest p × hypotheses |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['mesh']} | {r['case']} | - | - | - | {r['error']} |")
            continue
        lines.append(
            f"| {r['mesh']} | {r['case']} | {r['trials']} | {r['detected']} | {r['valid']} | "
            f"{r['min_p_h']:.3g} |"
        )
    good = [r for r in rows if "error" not in r]
    total = sum(r["trials"] for r in good)
    detected = sum(r["detected"] for r in good)
    valid = sum(r["valid"] for r in good)
    lines.append(
        f"\n{total} keyed trials: {detected} detections, {valid} {counted} "
        f"({time.perf_counter() - t0:.0f} s, FPR {FPR:g}, readers: "
        f"{', '.join(readers) if readers else 'all'})"
    )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)
    return 1 if detected else 0


if __name__ == "__main__":
    raise SystemExit(main())
