"""Acceptance check of issue #5: an embedded id survives what pipelines do to files.

For each mesh in ``../shared/meshes`` (or the files given), at N = 256 with the default
parameters (robust profile), an 8-byte id (the first 8 bytes of the SHA-256 of the mesh name)
is embedded with the key ``pipeline-<name>`` (:func:`meshwm.watermark.embed` with ``ident``), then
every operation below is applied to the marked mesh and the id is read back blind
(:func:`meshwm.watermark.extract_id`).  A cell passes ("ok") when the decoded id is the embedded
one, the bit error rate of the 256 code bits is 0 and the mark is detected
(:func:`meshwm.detect.decide` at a false-positive rate of 1e-6, Bonferroni-corrected by
the hypotheses extraction tried).

Operations (one row each):

- ``none``: the marked arrays as returned by ``embed`` (sanity);
- ``trimesh OBJ/PLY/STL/GLB``: ``trimesh.Trimesh(v, f, process=False).export(path)``, read back
  with :func:`meshwm.mesh.io.read_mesh`;
- ``pymeshlab OBJ/PLY/STL`` (GLB too if the installed pymeshlab can save it; if not, a note says
  so): ``MeshSet.save_current_mesh(path)``, read back with ``read_mesh``;
- ``reorder``: random vertex + face permutation and cyclic shift of each face's corners;
- ``float32``: coordinates rounded to single precision;
- ``quantize 16``: each axis snapped to 2**16 levels of its range (glTF KHR_mesh_quantization);
- ``similarity sN``: random rotation, translation (up to 10 diagonals), uniform scale
  (log-uniform in 0.01..100), three seeds;
- ``meshlab laplacian 3``: 3 steps of MeshLab's Laplacian smoothing;
- ``chain``: similarity -> float32 -> quantize 16 -> reorder -> pymeshlab PLY save -> read;
- ``weld ...``: pymeshlab ``meshing_merge_close_vertices`` at MeshLab's default threshold and at
  explicit thresholds in % of the marked mesh's bounding-box diagonal (``--weld-thresholds``).

About the welding threshold: the filter's ``threshold`` is a MeshLab "absolute or percentage"
value whose range is [0, diagonal/100], and ``pymeshlab.PercentageValue(p)`` is p % *of that
range*: the default "1 %" is diagonal/10000, i.e. 0.01 % of the diagonal.  This script passes
the explicit thresholds as ``pymeshlab.PureValue`` (absolute lengths) so that they mean what the
table says.  For each mesh it also measures the spacing of the grid samples (median length of the
horizontal/vertical grid edges) and the smallest distance between two distinct vertices of the
marked mesh, in % of the diagonal; welding merges vertices only above the latter.

Required rows: every row except welding above ``--weld-required-max`` % of the diagonal
(default 0.01, MeshLab's default threshold: what a pipeline uses to weld duplicates).  Larger
thresholds merge crowded grid samples by the hundred or thousand; they are reported as a
robustness curve, not required.  The exit status is 1 if a required cell fails (or a mesh
cannot be embedded).

Prints a Markdown table (rows = operations, columns = meshes), a summary line, the welding table
(vertices merged and result per threshold), the spacing table, and the seconds per mesh.  Takes
10 to 30 s per mesh (about 3 minutes for the 10 dev meshes on 2 cores).

    python scripts/check_pipeline.py
    python scripts/check_pipeline.py ../shared/meshes/spot.ply --json /tmp/pipeline.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pymeshlab
import trimesh
from numpy.typing import NDArray
from scipy.spatial import cKDTree

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MESHES = REPO_ROOT.parent / "shared" / "meshes"
MESH_SUFFIXES = (".ply", ".obj", ".off", ".stl", ".glb")

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

from _machine import machine_info  # noqa: E402

from meshwm.attacks.smoothing import meshlab_laplacian  # noqa: E402
from meshwm.attacks.transforms import float32, quantize, reorder, similarity  # noqa: E402
from meshwm.detect import decide  # noqa: E402
from meshwm.gim.recover import recover_grid  # noqa: E402
from meshwm.mesh.io import read_mesh  # noqa: E402
from meshwm.watermark import embed, extract_id  # noqa: E402

Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]

FPR = 1e-6
SIZE = 256
SIMILARITY_SEEDS = (1, 2, 3)
REORDER_SEED = 1
#: Explicit welding thresholds, in % of the bounding-box diagonal (0: exact duplicates only).
WELD_THRESHOLDS = (0.0, 1e-5, 1e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 1.0)
WELD_DEFAULT = "weld MeshLab default (0.01 %)"


# --------------------------------------------------------------------------------------------
# Operations
# --------------------------------------------------------------------------------------------


def trimesh_round_trip(v: NDArray, f: NDArray, path: Path) -> Mesh:
    """Write with trimesh (no processing), read back with meshwm.mesh.io.read_mesh."""
    trimesh.Trimesh(v, f, process=False).export(path)
    try:
        return read_mesh(path)
    finally:
        path.unlink(missing_ok=True)


def _meshset(v: NDArray, f: NDArray) -> pymeshlab.MeshSet:
    ms = pymeshlab.MeshSet()
    ms.add_mesh(
        pymeshlab.Mesh(
            vertex_matrix=np.asarray(v, dtype=np.float64),
            face_matrix=np.asarray(f).astype(np.int32),
        )
    )
    return ms


def pymeshlab_round_trip(v: NDArray, f: NDArray, path: Path) -> Mesh:
    """Save with pymeshlab (its default options), read back with meshwm.mesh.io.read_mesh."""
    _meshset(v, f).save_current_mesh(str(path))
    try:
        return read_mesh(path)
    finally:
        path.unlink(missing_ok=True)


def pymeshlab_can_save(suffix: str, tmp: Path) -> str | None:
    """None if pymeshlab saves ``suffix`` files, else its error message."""
    path = tmp / f"probe{suffix}"
    try:
        _meshset(np.eye(3), np.array([[0, 1, 2]])).save_current_mesh(str(path))
    except pymeshlab.PyMeshLabException as exc:
        return str(exc).strip()
    finally:
        path.unlink(missing_ok=True)
    return None


def weld(v: NDArray, f: NDArray, threshold: Any | None) -> Mesh:
    """pymeshlab ``meshing_merge_close_vertices`` (its default threshold if None)."""
    ms = _meshset(v, f)
    if threshold is None:
        ms.meshing_merge_close_vertices()
    else:
        ms.meshing_merge_close_vertices(threshold=threshold)
    m = ms.current_mesh()
    return (
        np.array(m.vertex_matrix(), dtype=np.float64),
        np.array(m.face_matrix(), dtype=np.int64),
    )


def chain(v: NDArray, f: NDArray, path: Path) -> Mesh:
    """similarity -> float32 -> quantize 16 -> reorder -> pymeshlab PLY save -> read."""
    v, f = similarity(v, f, seed=SIMILARITY_SEEDS[0])
    v, f = float32(v, f)
    v, f = quantize(v, f, bits=16)
    v, f = reorder(v, f, seed=REORDER_SEED)
    return pymeshlab_round_trip(v, f, path)


def operations(tmp: Path, glb_error: str | None) -> dict[str, Callable[[NDArray, NDArray], Mesh]]:
    """The non-welding rows: name -> operation on the marked mesh."""
    ops: dict[str, Callable[[NDArray, NDArray], Mesh]] = {"none": lambda v, f: (v, f)}
    for suffix in (".obj", ".ply", ".stl", ".glb"):
        ops[f"trimesh {suffix[1:].upper()}"] = lambda v, f, s=suffix: trimesh_round_trip(
            v, f, tmp / f"trimesh{s}"
        )
    for suffix in (".obj", ".ply", ".stl", ".glb"):
        if suffix == ".glb" and glb_error is not None:
            continue
        ops[f"pymeshlab {suffix[1:].upper()}"] = lambda v, f, s=suffix: pymeshlab_round_trip(
            v, f, tmp / f"pymeshlab{s}"
        )
    ops[f"reorder (seed {REORDER_SEED})"] = lambda v, f: reorder(v, f, seed=REORDER_SEED)
    ops["float32"] = float32
    ops["quantize 16 bits"] = lambda v, f: quantize(v, f, bits=16)
    for seed in SIMILARITY_SEEDS:
        ops[f"similarity (seed {seed})"] = lambda v, f, s=seed: similarity(v, f, seed=s)
    ops["meshlab laplacian 3 steps"] = lambda v, f: meshlab_laplacian(v, f, iterations=3)
    ops["chain sim→f32→q16→reorder→pymeshlab PLY"] = lambda v, f: chain(v, f, tmp / "chain.ply")
    return ops


def weld_name(percent: float) -> str:
    return f"weld {percent:g} %"


# --------------------------------------------------------------------------------------------
# Checking
# --------------------------------------------------------------------------------------------


def spacing(v: NDArray, f: NDArray) -> dict[str, float]:
    """Grid-sample spacing and closest vertex pair of a marked mesh, in % of its diagonal."""
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    index = recover_grid(v, f).index
    a = np.concatenate([index[:-1, :].ravel(), index[:, :-1].ravel()])
    b = np.concatenate([index[1:, :].ravel(), index[:, 1:].ravel()])
    keep = (a >= 0) & (b >= 0) & (a != b)  # welded samples share a vertex
    edges = np.linalg.norm(v[a[keep]] - v[b[keep]], axis=1) / diag * 100
    nearest = cKDTree(v).query(v, k=2)[0][:, 1] / diag * 100
    mesh_edges = np.unique(np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    lengths = np.linalg.norm(v[mesh_edges[:, 0]] - v[mesh_edges[:, 1]], axis=1) / diag * 100
    return {
        "diagonal": diag,
        "grid_edge_median_pct": float(np.median(edges)),
        "grid_edge_min_pct": float(edges.min()),
        "mesh_edge_min_pct": float(lengths.min()),
        "nearest_vertex_min_pct": float(nearest.min()),
        "nearest_vertex_p1_pct": float(np.percentile(nearest, 1)),
    }


def judge(v: NDArray, f: NDArray, key: str, ident: bytes) -> dict[str, Any]:
    """Extract the id and grade the read; errors are a failed read, not a crash."""
    out: dict[str, Any] = {"vertices": len(v), "faces": len(f)}
    try:
        got = extract_id(v, f, key=key, expected=ident)
    except Exception as exc:  # GridError, MeshError, ...: the id is gone
        out.update(ok=False, error=f"{type(exc).__name__}: {str(exc).splitlines()[0][:160]}")
        return out
    r = got.report
    detected = decide(r, fpr=FPR).detected
    out.update(
        id=got.id,
        id_ok=got.id == ident.hex(),
        ber=float(r["ber"]),
        p_value=float(r["p_value"]),
        hypotheses=int(r["hypotheses"]),
        detected=detected,
        seconds=float(r["seconds"]),
    )
    out["ok"] = bool(out["id_ok"] and out["ber"] == 0 and detected)
    return out


def cell(result: dict[str, Any]) -> str:
    if result.get("skipped"):
        return "n/a"
    if result["ok"]:
        return "ok"
    if "error" in result:
        return result["error"].split(":")[0]
    text = f"BER {result['ber']:.3f}"
    if not result["id_ok"]:
        text += ", no id" if result["id"] is None else f", id {result['id']}"
    if not result["detected"]:
        text += ", not detected"
    return text


def check_mesh(
    path: Path,
    tmp: Path,
    glb_error: str | None,
    thresholds: tuple[float, ...],
    required_max: float,
) -> dict[str, Any]:
    name = path.stem
    ident = hashlib.sha256(name.encode()).digest()[:8]
    key = f"pipeline-{name}"
    v, f = read_mesh(path)
    res = embed(v, f, key=key, ident=ident, distances=False, grid=True)
    if res.report["n"] != SIZE or res.report["profile"] != "robust":
        got = f"N = {res.report['n']}, {res.report['profile']}"
        raise RuntimeError(f"the default parameters changed ({got})")
    mv, mf = res.vertices, res.faces
    del v, f
    row: dict[str, Any] = {
        "mesh": name,
        "id": ident.hex(),
        "key": key,
        "marked_vertices": len(mv),
        "marked_faces": len(mf),
        "embed_seconds": float(res.report["seconds"]),
        "spacing": spacing(mv, mf),
        "ops": {},
        "weld": {},
    }
    t_ops = time.perf_counter()
    for op, fn in operations(tmp, glb_error).items():
        try:
            v2, f2 = fn(mv, mf)
        except Exception as exc:  # the operation itself failed: report, do not crash
            row["ops"][op] = {"ok": False, "error": f"{type(exc).__name__} in operation: {exc}"}
            continue
        row["ops"][op] = judge(v2, np.asarray(f2, dtype=np.int64), key, ident)
    diag = row["spacing"]["diagonal"]
    welds: list[tuple[str, float | None, Any]] = [(WELD_DEFAULT, None, None)]
    welds += [(weld_name(p), p, pymeshlab.PureValue(p / 100 * diag)) for p in thresholds]
    for op, percent, threshold in welds:
        v2, f2 = weld(mv, mf, threshold)
        result = judge(v2, f2, key, ident)
        # MeshLab's default: diagonal / 10000 of the mesh it is applied to.
        pct = 0.01 if percent is None else percent
        result.update(
            threshold_pct=pct,
            merged=len(mv) - len(v2),
            faces_removed=len(mf) - len(f2),
            required=pct <= required_max + 1e-12,
        )
        row["weld"][op] = result
    row["ops_seconds"] = time.perf_counter() - t_ops
    row["extract_seconds"] = row["ops"]["none"].get("seconds", float("nan"))
    reads = [r["seconds"] for r in [*row["ops"].values(), *row["weld"].values()] if "seconds" in r]
    row["extract_seconds_mean"] = float(np.mean(reads)) if reads else float("nan")
    failed = [op for op, r in row["ops"].items() if not r["ok"]]
    failed += [op for op, r in row["weld"].items() if r["required"] and not r["ok"]]
    row["required_failed"] = failed
    return row


# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------


def print_tables(rows: list[dict[str, Any]], required_max: float, glb_error: str | None) -> int:
    """Print every table; the number of required cells that fail."""
    meshes = [r["mesh"] for r in rows]
    names = list(rows[0]["ops"]) + list(rows[0]["weld"])
    print("| operation | " + " | ".join(meshes) + " |")
    print("|---|" + "---|" * len(meshes))
    required_ops = 0
    passing_ops = 0
    failures = 0
    for op in names:
        results = [r["ops"].get(op) or r["weld"][op] for r in rows]
        required = [x.get("required", True) for x in results]
        label = op
        if not any(required):
            label += " (not required)"
        elif not all(required):
            label += f" (required on {sum(required)}/{len(required)})"
        cells = []
        for x, req in zip(results, required, strict=True):
            text = cell(x)
            if not x["ok"] and not req:
                text += " (not req.)"
            cells.append(text)
        print(f"| {label} | " + " | ".join(cells) + " |")
        failures += sum(req and not x["ok"] for x, req in zip(results, required, strict=True))
        if all(required):
            required_ops += 1
            passing_ops += all(x["ok"] for x in results)
    print(
        f"\n{passing_ops}/{required_ops} required operations pass on every mesh "
        f"({len(names)} rows; {failures} required cells fail)."
    )
    print(
        "Required: every row except welding above "
        f"{required_max:g} % of the diagonal (MeshLab's default welding threshold; larger ones "
        "are a robustness curve, not a clean-up); "
        "cell 'ok' = id decoded, BER 0 and detected at FPR 1e-6 (Bonferroni)."
    )
    if glb_error is not None:
        print(f"pymeshlab GLB: not checked, pymeshlab cannot save it ({glb_error}).")

    print("\nWelding (pymeshlab meshing_merge_close_vertices): vertices merged / result")
    print("\n| threshold (% of diagonal) | " + " | ".join(meshes) + " |")
    print("|---|" + "---|" * len(meshes))
    for op in rows[0]["weld"]:
        results = [r["weld"][op] for r in rows]
        pct = results[0]["threshold_pct"]
        label = f"{pct:g}" + (" (MeshLab default: diagonal/10000)" if op == WELD_DEFAULT else "")
        cells = [f"{x['merged']} / {cell(x)}" for x in results]
        print(f"| {label} | " + " | ".join(cells) + " |")

    print(
        "\n| mesh | V marked | median grid edge % | min grid edge % | min mesh edge % | "
        "min vertex gap % | 1st pct vertex gap % | embed s | extract s | all rows s |"
    )
    print("|---|" + "---|" * 9)
    for r in rows:
        s = r["spacing"]
        print(
            f"| {r['mesh']} | {r['marked_vertices']} | {s['grid_edge_median_pct']:.3f} | "
            f"{s['grid_edge_min_pct']:.4f} | {s['mesh_edge_min_pct']:.5f} | "
            f"{s['nearest_vertex_min_pct']:.5f} | "
            f"{s['nearest_vertex_p1_pct']:.4f} | {r['embed_seconds']:.1f} | "
            f"{r['extract_seconds']:.2f} | {r['ops_seconds']:.0f} |"
        )
    return failures


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("meshes", nargs="*", type=Path, help=f"default: {DEFAULT_MESHES}/*")
    parser.add_argument("--json", type=Path, help="also write the results as JSON to this file")
    parser.add_argument(
        "--weld-thresholds",
        type=float,
        nargs="+",
        default=list(WELD_THRESHOLDS),
        help="explicit welding thresholds in %% of the bounding-box diagonal "
        f"(default {' '.join(f'{p:g}' for p in WELD_THRESHOLDS)})",
    )
    parser.add_argument(
        "--weld-required-max",
        type=float,
        default=0.01,
        help="a welding row is required when its threshold is at most this %% of the "
        "bounding-box diagonal (default 0.01: MeshLab's default, diagonal/10000)",
    )
    args = parser.parse_args(argv)
    paths = args.meshes or sorted(
        p for p in DEFAULT_MESHES.iterdir() if p.suffix.lower() in MESH_SUFFIXES
    )
    machine = machine_info("trimesh", "pymeshlab", "scipy")
    rows: list[dict[str, Any]] = []
    broken: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        glb_error = pymeshlab_can_save(".glb", tmp)
        for path in paths:
            t0 = time.perf_counter()
            try:
                rows.append(
                    check_mesh(
                        path,
                        tmp,
                        glb_error,
                        tuple(args.weld_thresholds),
                        args.weld_required_max,
                    )
                )
            except Exception as exc:  # embedding failed: the mesh fails, the others still run
                traceback.print_exc()
                broken[path.stem] = f"{type(exc).__name__}: {exc}"
            seconds = time.perf_counter() - t0
            print(f"  done {path.name} ({seconds:.0f} s)", file=sys.stderr, flush=True)
    print(f"meshwm pipeline check, N = {SIZE}, robust profile; machine: {machine}\n")
    failures = print_tables(rows, args.weld_required_max, glb_error) if rows else 0
    for name, error in broken.items():
        print(f"\n{name}: could not be checked ({error})")
    if args.json is not None:
        payload = {
            "machine": machine,
            "size": SIZE,
            "fpr": FPR,
            "weld_required_max": args.weld_required_max,
            "pymeshlab_glb": glb_error or "supported",
            "rows": rows,
            "broken": broken,
        }
        args.json.write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n")
        print(f"\nwrote {args.json}")
    return 1 if failures or broken else 0


if __name__ == "__main__":
    sys.exit(main())
