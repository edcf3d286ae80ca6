"""Acceptance check of the remesh stage (mesh -> geometry image -> mesh) over the dev meshes.

For every ``*.ply`` in the meshes directory (default ``../shared/meshes`` next to the repository,
loaded with ``trimesh.load(path, process=False)``) the mesh is turned into a geometry image with
:func:`meshwm.gim.remesh.mesh_to_geometry_image` at ``--size`` and back into a mesh with
:func:`meshwm.gim.to_mesh.geometry_image_to_mesh` (seams welded, other components passed
through), and one Markdown table row is printed with:

V in, F in, V out, F out, s
    Sizes of the input and of the rebuilt output, and the wall time of the first
    ``mesh_to_geometry_image`` call.
NaN
    Non-finite values (NaN or inf) in the image.  Requirement: none.
H %, RMS %
    Two-sided surface distance input <-> output (:func:`meshwm.metrics.surface_distance`,
    pymeshlab), the symmetric Hausdorff distance and the larger one-sided RMS distance, in % of
    the input's bounding-box diagonal.  Requirements: H <= 1 %, RMS <= 0.2 %.
wt in→out, closed g0 → wt
    trimesh ``is_watertight`` of the whole input and of the whole output (passed-through
    components included).  For inputs that are closed genus 0 (watertight, and the report of the
    main component says no boundary loop and genus 0) the output must be watertight: pass/fail;
    other inputs show ``n/a``.
χ in→out
    Euler characteristic V - E + F of the main component: the input's is the report's
    ``euler_characteristic`` (largest component after cleaning), the output's is computed over
    the *grid part only* (``geometry_image_to_mesh(gim, weld)`` without the passed-through
    components), since those components are copied unchanged and only the grid is the remeshed
    main component.  Informative (a kept χ means the cut seams were welded back correctly).
flip, chains, paths
    ``flipped_triangles``, ``chains`` and ``cut_paths`` from the report.
det
    Determinism: the same input (fresh copies of the arrays) remeshed twice gives a
    byte-identical image (``np.array_equal`` and identical ``.tobytes()``) and the same weld map.
    Requirement.
sim dev
    Similarity invariance, ``--trials`` trials with different seeds, the worst one shown: the input
    is transformed by ``x -> s R x + t`` (R from ``scipy.spatial.transform.Rotation.random``,
    s log-uniform in [0.01, 100], t in a uniformly random direction with a length uniform in
    [0, 10 s d], d the input's bounding-box diagonal) and remeshed; the image must equal the
    original image transformed the same way: max vertex deviation divided by the bounding-box
    diagonal of the transformed input <= 1e-6, and the weld map identical.  Requirement.
perm dev
    Element-order invariance: a random vertex permutation, a random face permutation and a random
    cyclic rotation of each face's corners (which keeps its orientation); the max deviation from
    the original image relative to the diagonal, ``same`` if <= 1e-6 (and the weld map equal),
    else ``differs``.  Informative: an aim, not a requirement (exact ties in the cut's choices can
    legitimately depend on the order).

Every mesh is remeshed 3 + ``--trials`` times (original, determinism repeat, the similarity
trials, the permutation).  A summary line at the end says how many meshes pass each requirement;
the exit status is 1 if any mesh fails a requirement (or cannot be remeshed), else 0.  Progress
goes to stderr, the table to stdout.  Seeds are derived from ``--seed``, the mesh file name and
the trial number, so a subset run (``--only``) reproduces the rows of a full run.

How to run
----------
From the repository root (no install needed)::

    python scripts/check_remesh.py                      # all meshes, N = 256, 2 trials
    python scripts/check_remesh.py --trials 1 --json remesh.json
    python scripts/check_remesh.py --only spot cow --size 128
    python scripts/check_remesh.py --meshes path/to/dir

The run over the 10 dev meshes takes several minutes (igea, 134k vertices, takes ~5 s per
remesh).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import zlib
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

import numpy as np  # noqa: E402
import trimesh  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from meshwm.gim.remesh import mesh_to_geometry_image  # noqa: E402
from meshwm.gim.to_mesh import geometry_image_to_mesh  # noqa: E402
from meshwm.mesh.clean import unique_edges  # noqa: E402
from meshwm.metrics import bounding_box_diagonal, surface_distance  # noqa: E402

HAUSDORFF_TARGET = 1.0  # % of the bounding-box diagonal
RMS_TARGET = 0.2  # % of the bounding-box diagonal
INVARIANCE_TARGET = 1e-6  # max vertex deviation / bounding-box diagonal

COLUMNS = [
    ("mesh", "---"),
    ("V in", "---:"),
    ("F in", "---:"),
    ("V out", "---:"),
    ("F out", "---:"),
    ("s", "---:"),
    ("NaN", "---:"),
    ("H % (≤1)", "---"),
    ("RMS % (≤0.2)", "---"),
    ("wt in→out", "---"),
    ("closed g0 → wt", "---"),
    ("χ in→out", "---"),
    ("flip", "---:"),
    ("chains", "---:"),
    ("paths", "---:"),
    ("det", "---"),
    ("sim dev (≤1e-6)", "---"),
    ("perm dev", "---"),
]

# Requirements counted in the summary: (key in the row, label).
REQUIREMENTS = [
    ("ok_nan", "no NaN"),
    ("ok_hausdorff", "Hausdorff ≤ 1 %"),
    ("ok_rms", "RMS ≤ 0.2 %"),
    ("ok_watertight", "closed g0 → watertight"),
    ("ok_deterministic", "deterministic"),
    ("ok_similarity", "similarity ≤ 1e-6 + same weld"),
]
INFORMATIVE = [
    ("ok_euler", "χ kept"),
    ("ok_permutation", "permutation same"),
    ("ok_no_flip", "no flipped triangle"),
]


def log(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def load(path: Path) -> tuple[np.ndarray, np.ndarray]:
    mesh = trimesh.load(path, process=False)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def is_watertight(vertices: np.ndarray, faces: np.ndarray) -> bool:
    return bool(trimesh.Trimesh(vertices, faces, process=False).is_watertight)


def euler(vertices: np.ndarray, faces: np.ndarray) -> int:
    """V - E + F, counting only the vertices that faces use."""
    if len(faces) == 0:
        return 0
    n_used = len(np.unique(faces))
    return int(n_used - len(unique_edges(faces)[0]) + len(faces))


def max_deviation(a: np.ndarray, b: np.ndarray, diagonal: float) -> float:
    """Largest Euclidean distance between corresponding samples, relative to ``diagonal``."""
    if a.shape != b.shape:
        return float("inf")
    d = np.linalg.norm(a.reshape(-1, 3) - b.reshape(-1, 3), axis=1)
    return float(np.max(d) / diagonal) if d.size else 0.0


def seed_for(base: int, name: str, tag: int, trial: int) -> np.random.Generator:
    return np.random.default_rng([base, zlib.crc32(name.encode()), tag, trial])


def similarity_trial(v: np.ndarray, f: np.ndarray, g0, size: int, rng: np.random.Generator) -> dict:
    """Remesh a randomly rotated, scaled and translated copy and compare with the original."""
    diagonal = bounding_box_diagonal(v)
    rot = Rotation.random(random_state=rng).as_matrix()
    scale = float(10.0 ** rng.uniform(-2.0, 2.0))
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    shift = direction * rng.uniform(0.0, 10.0) * scale * diagonal
    matrix = scale * rot

    vt = v @ matrix.T + shift
    gt = mesh_to_geometry_image(vt, f.copy(), size=size)
    expected = g0.gim @ matrix.T + shift
    dev = max_deviation(gt.gim, expected, bounding_box_diagonal(vt))
    return {
        "scale": scale,
        "shift_rel": float(np.linalg.norm(shift) / (scale * diagonal)),
        "deviation": dev,
        "weld_equal": bool(np.array_equal(gt.weld, g0.weld)),
    }


def permutation_trial(v: np.ndarray, f: np.ndarray, g0, size: int, rng) -> dict:
    """Remesh the same mesh with vertices, faces and face corners reordered."""
    perm = rng.permutation(len(v))  # new vertex k is old vertex perm[k]
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))
    fp = inverse[f][rng.permutation(len(f))]
    shift = rng.integers(0, 3, size=len(fp))
    cols = (np.arange(3)[None, :] + shift[:, None]) % 3
    fp = np.take_along_axis(fp, cols, axis=1)
    gp = mesh_to_geometry_image(v[perm], fp, size=size)
    dev = max_deviation(gp.gim, g0.gim, bounding_box_diagonal(v))
    weld_equal = bool(np.array_equal(gp.weld, g0.weld))
    return {
        "deviation": dev,
        "weld_equal": weld_equal,
        "same": bool(dev <= INVARIANCE_TARGET and weld_equal),
    }


def check_mesh(path: Path, size: int, trials: int, seed: int) -> dict:
    name = path.stem
    v, f = load(path)
    row: dict = {"mesh": name, "vertices_in": len(v), "faces_in": len(f)}
    log(f"[{name}] V={len(v)} F={len(f)}: geometry image N={size} ...")

    t0 = time.perf_counter()
    g0 = mesh_to_geometry_image(v.copy(), f.copy(), size=size)
    row["seconds"] = time.perf_counter() - t0
    rep = g0.report
    vo, fo = geometry_image_to_mesh(
        g0.gim, g0.weld, other_vertices=g0.other_vertices, other_faces=g0.other_faces
    )
    row["vertices_out"], row["faces_out"] = len(vo), len(fo)

    row["non_finite"] = int(np.sum(~np.isfinite(g0.gim)))
    row["ok_nan"] = row["non_finite"] == 0

    log(f"[{name}] {row['seconds']:.2f} s; surface distance ...")
    if row["ok_nan"]:
        sd = surface_distance(v, f, vo, fo)
        row["hausdorff_rel_pct"] = 100.0 * sd.hausdorff / sd.diagonal
        row["rms_rel_pct"] = 100.0 * sd.rms / sd.diagonal
    else:
        row["hausdorff_rel_pct"] = row["rms_rel_pct"] = float("nan")
    row["ok_hausdorff"] = bool(row["hausdorff_rel_pct"] <= HAUSDORFF_TARGET)
    row["ok_rms"] = bool(row["rms_rel_pct"] <= RMS_TARGET)

    row["watertight_in"] = is_watertight(v, f)
    row["watertight_out"] = is_watertight(vo, fo)
    closed_g0 = bool(
        row["watertight_in"] and rep.get("boundary_loops") == 0 and rep.get("genus") == 0
    )
    row["closed_genus0"] = closed_g0
    row["ok_watertight"] = row["watertight_out"] if closed_g0 else None

    vg, fg = geometry_image_to_mesh(g0.gim, g0.weld)  # grid part only
    row["euler_in"] = int(rep["euler_characteristic"])
    row["euler_out"] = euler(vg, fg)
    row["ok_euler"] = row["euler_in"] == row["euler_out"]

    row["flipped_triangles"] = int(rep.get("flipped_triangles", -1))
    row["ok_no_flip"] = row["flipped_triangles"] == 0
    row["chains"] = rep.get("chains")
    row["cut_paths"] = rep.get("cut_paths")
    row["report"] = {k: val for k, val in rep.items() if isinstance(val, int | float | str)}

    log(f"[{name}] determinism ...")
    g1 = mesh_to_geometry_image(v.copy(), f.copy(), size=size)
    row["ok_deterministic"] = bool(
        np.array_equal(g0.gim, g1.gim)
        and g0.gim.tobytes() == g1.gim.tobytes()
        and np.array_equal(g0.weld, g1.weld)
    )

    sims = []
    for trial in range(trials):
        log(f"[{name}] similarity trial {trial + 1}/{trials} ...")
        sims.append(similarity_trial(v, f, g0, size, seed_for(seed, name, 1, trial)))
    row["similarity_trials"] = sims
    if sims:
        row["similarity_deviation"] = max(s["deviation"] for s in sims)
        row["similarity_weld_equal"] = all(s["weld_equal"] for s in sims)
        row["ok_similarity"] = bool(
            row["similarity_deviation"] <= INVARIANCE_TARGET and row["similarity_weld_equal"]
        )
    else:
        row["similarity_deviation"] = None
        row["similarity_weld_equal"] = None
        row["ok_similarity"] = None

    log(f"[{name}] permutation ...")
    perm = permutation_trial(v, f, g0, size, seed_for(seed, name, 2, 0))
    row["permutation_deviation"] = perm["deviation"]
    row["permutation_weld_equal"] = perm["weld_equal"]
    row["ok_permutation"] = perm["same"]
    log(f"[{name}] done")
    return row


def _pf(ok: bool | None) -> str:
    return "n/a" if ok is None else ("pass" if ok else "**FAIL**")


def _yn(flag: bool) -> str:
    return "yes" if flag else "no"


def format_row(row: dict) -> str:
    if "error" in row:
        cells = [row["mesh"], "**ERROR**: " + row["error"]] + [""] * (len(COLUMNS) - 2)
        return "| " + " | ".join(cells) + " |"
    if row["similarity_deviation"] is None:
        sim = "n/a"
    else:
        sim = f"{row['similarity_deviation']:.1e} {_pf(row['ok_similarity'])}"
        if not row["similarity_weld_equal"]:
            sim += " (weld differs)"
    perm = f"{row['permutation_deviation']:.1e} " + ("same" if row["ok_permutation"] else "differs")
    if not row["permutation_weld_equal"]:
        perm += " (weld differs)"
    cells = [
        row["mesh"],
        str(row["vertices_in"]),
        str(row["faces_in"]),
        str(row["vertices_out"]),
        str(row["faces_out"]),
        f"{row['seconds']:.2f}",
        str(row["non_finite"]) if row["ok_nan"] else f"**{row['non_finite']}**",
        f"{row['hausdorff_rel_pct']:.3f} {_pf(row['ok_hausdorff'])}",
        f"{row['rms_rel_pct']:.4f} {_pf(row['ok_rms'])}",
        f"{_yn(row['watertight_in'])}→{_yn(row['watertight_out'])}",
        _pf(row["ok_watertight"]),
        f"{row['euler_in']}→{row['euler_out']}" + ("" if row["ok_euler"] else " (differs)"),
        str(row["flipped_triangles"]),
        str(row["chains"]),
        str(row["cut_paths"]),
        _pf(row["ok_deterministic"]),
        sim,
        perm,
    ]
    return "| " + " | ".join(cells) + " |"


def summary(rows: list[dict]) -> tuple[str, bool]:
    parts, all_ok = [], True
    for key, label in REQUIREMENTS:
        values = [r.get(key) if "error" not in r else False for r in rows]
        applicable = [x for x in values if x is not None]
        passed = sum(bool(x) for x in applicable)
        all_ok &= passed == len(applicable)
        parts.append(f"{label} {passed}/{len(applicable)}")
    info = []
    for key, label in INFORMATIVE:
        values = [r.get(key) for r in rows if "error" not in r]
        info.append(f"{label} {sum(bool(x) for x in values)}/{len(values)}")
    errors = sum("error" in r for r in rows)
    text = f"**Summary** ({len(rows)} meshes): pass: " + ", ".join(parts)
    text += "; informative: " + ", ".join(info)
    if errors:
        text += f"; {errors} mesh(es) could not be remeshed"
    return text + ".", all_ok


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshes", type=Path, default=DEFAULT_MESHES, help="directory of *.ply")
    parser.add_argument("--size", type=int, default=256, help="geometry image size N")
    parser.add_argument("--trials", type=int, default=2, help="similarity trials per mesh")
    parser.add_argument("--seed", type=int, default=0, help="base seed of the random trials")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="mesh names (stem or file)")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the rows as JSON")
    args = parser.parse_args(argv)

    paths = sorted(args.meshes.glob("*.ply"))
    if args.only:
        wanted = {Path(name).stem for name in args.only}
        missing = wanted - {p.stem for p in paths}
        if missing:
            parser.error(f"not in {args.meshes}: {', '.join(sorted(missing))}")
        paths = [p for p in paths if p.stem in wanted]
    if not paths:
        parser.error(f"no *.ply files in {args.meshes}")

    rows = []
    t_start = time.perf_counter()
    for k, path in enumerate(paths):
        log(f"--- {k + 1}/{len(paths)}: {path.name}")
        try:
            rows.append(check_mesh(path, args.size, args.trials, args.seed))
        except Exception as exc:  # one bad mesh must not stop the check of the others
            log(f"[{path.stem}] ERROR {type(exc).__name__}: {exc}")
            rows.append({"mesh": path.stem, "error": f"{type(exc).__name__}: {exc}"})
    log(f"total {time.perf_counter() - t_start:.1f} s")

    print(
        f"Remesh acceptance check, N = {args.size}, {args.trials} similarity trial(s), "
        f"seed {args.seed}, meshes in {args.meshes}\n"
    )
    print("| " + " | ".join(c for c, _ in COLUMNS) + " |")
    print("|" + "|".join(a for _, a in COLUMNS) + "|")
    for row in rows:
        print(format_row(row))
    text, all_ok = summary(rows)
    print()
    print(text)

    if args.json:
        payload = {
            "size": args.size,
            "trials": args.trials,
            "seed": args.seed,
            "meshes": str(args.meshes),
            "rows": rows,
            "summary": text,
        }
        args.json.write_text(json.dumps(_jsonable(payload), indent=2) + "\n", encoding="utf-8")
        log(f"rows written to {args.json}")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
