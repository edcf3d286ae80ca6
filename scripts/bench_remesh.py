"""Benchmark the remesh stage (mesh -> geometry image -> mesh) against a one-solve floor.

What it measures
----------------
For one mesh (by default the ``*.ply`` with the most faces in ``../shared/meshes``, today
``igea.ply``, 268,686 faces) and each grid size N (default 256 and 512):

remesh
    The full stage as a user runs it, from file to file:
    ``meshwm.mesh.io.read_mesh(path)``, ``meshwm.gim.remesh.mesh_to_geometry_image(v, f, size=N)``,
    ``meshwm.gim.to_mesh.geometry_image_to_mesh(...)`` and ``meshwm.mesh.io.write_mesh`` into a
    temporary directory.  Median wall time over ``--repeats`` runs.
floor
    What the stage cannot go below: ``read_mesh`` of the same file plus ONE
    ``igl.harmonic(V, F, b, bc, 1)`` solve on that mesh.  ``b`` is every k-th vertex, as many
    as the remesh fixes (the boundary loop of the cut-open disk, ``2 * cut_edges`` from the
    report of the warm-up run; 1% of the vertices if the report has no ``cut_edges``), and
    ``bc`` puts them on the unit circle.  Median wall time over the same number of runs.

The ratio remesh / floor is printed next to its target (≤ 3).  One extra remesh run per N,
made first (it also warms caches), is timed phase by phase (read / geometry image / to mesh /
write) and its report (``chains``, ``cut_paths``, ``cut_rounds``, ``stretch_iterations``,
``flipped_triangles``) is printed.  Nothing is asserted: the script only prints figures.

How to run
----------
From the repository root (no install needed)::

    python scripts/bench_remesh.py
    python scripts/bench_remesh.py --sizes 256 --repeats 3
    python scripts/bench_remesh.py --mesh path/to/other.ply --json bench.json

The igea run takes a few minutes (one remesh is several seconds at N = 256).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MESHES = REPO_ROOT.parent / "shared" / "meshes"
TARGET_RATIO = 3.0
REPORT_KEYS = ("chains", "cut_paths", "cut_rounds", "stretch_iterations", "flipped_triangles")

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

import igl  # noqa: E402
import numpy as np  # noqa: E402
from _machine import machine_info  # noqa: E402

from meshwm.gim import remesh as gi  # noqa: E402
from meshwm.gim import to_mesh  # noqa: E402
from meshwm.mesh import io as mio  # noqa: E402


def _ply_face_count(path: Path) -> int:
    """Faces declared in a PLY header (-1 if the header cannot be read)."""
    try:
        with open(path, "rb") as stream:
            for _ in range(200):
                line = stream.readline()
                if not line or line.strip() == b"end_header":
                    break
                parts = line.split()
                if len(parts) == 3 and parts[0] == b"element" and parts[1] == b"face":
                    return int(parts[2])
    except (OSError, ValueError):
        pass
    return -1


def largest_mesh(directory: Path) -> Path:
    """The ``*.ply`` in ``directory`` with the most faces (ties: first by name)."""
    candidates = sorted(directory.glob("*.ply"))
    if not candidates:
        raise SystemExit(f"no *.ply files in {directory}")
    counts = []
    for path in candidates:
        n = _ply_face_count(path)
        if n < 0:  # header not parseable: read the file
            n = len(mio.read_mesh(path)[1])
        counts.append(n)
    return candidates[int(np.argmax(counts))]


def remesh_once(path: Path, size: int, out: Path) -> tuple[dict[str, float], dict]:
    """One full remesh of ``path`` at ``size``; returns phase times and the report."""
    t0 = time.perf_counter()
    v, f = mio.read_mesh(path)
    t1 = time.perf_counter()
    g = gi.mesh_to_geometry_image(v, f, size=size)
    t2 = time.perf_counter()
    vo, fo = to_mesh.geometry_image_to_mesh(
        g.gim, g.weld, other_vertices=g.other_vertices, other_faces=g.other_faces
    )
    t3 = time.perf_counter()
    mio.write_mesh(out, vo, fo)
    t4 = time.perf_counter()
    phases = {
        "read": t1 - t0,
        "geometry_image": t2 - t1,
        "to_mesh": t3 - t2,
        "write": t4 - t3,
        "total": t4 - t0,
    }
    return phases, dict(g.report)


def boundary_set(n_vertices: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` vertices, every k-th, and their positions on the unit circle."""
    count = int(min(max(count, 3), n_vertices))
    b = np.linspace(0, n_vertices - 1, count).round().astype(np.int64)
    b = np.unique(b)
    angle = 2.0 * np.pi * np.arange(len(b)) / len(b)
    bc = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    return b, bc


def floor_once(path: Path, b: np.ndarray, bc: np.ndarray) -> float:
    """``read_mesh`` plus one harmonic solve with ``b`` fixed at ``bc``."""
    t0 = time.perf_counter()
    v, f = mio.read_mesh(path)
    v = np.ascontiguousarray(v, dtype=np.float64)
    f = np.ascontiguousarray(f, dtype=np.int64)
    igl.harmonic(v, f, b, bc, 1)
    return time.perf_counter() - t0


def bench(path: Path, sizes: list[int], repeats: int) -> list[dict]:
    v, f = mio.read_mesh(path)
    n_v, n_f = len(v), len(f)
    del v, f
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_remesh_") as tmp:
        out = Path(tmp) / "out.ply"
        for size in sizes:
            print(f"[{path.name} N={size}] phase run (warm-up) ...", file=sys.stderr, flush=True)
            phases, report = remesh_once(path, size, out)

            remesh_times = []
            for i in range(repeats):
                remesh_times.append(remesh_once(path, size, out)[0]["total"])
                print(
                    f"[{path.name} N={size}] remesh {i + 1}/{repeats}: {remesh_times[-1]:.2f} s",
                    file=sys.stderr,
                    flush=True,
                )

            cut_edges = report.get("cut_edges")
            if isinstance(cut_edges, int | np.integer) and cut_edges > 0:
                b, bc = boundary_set(n_v, 2 * int(cut_edges))
                how = f"every k-th vertex, count = 2 * cut_edges = {len(b)}, on the unit circle"
            else:
                b, bc = boundary_set(n_v, round(0.01 * n_v))
                how = f"every k-th vertex, 1% of V = {len(b)}, on the unit circle"
            floor_times = [floor_once(path, b, bc) for _ in range(repeats)]

            remesh_med = statistics.median(remesh_times)
            floor_med = statistics.median(floor_times)
            rows.append(
                {
                    "mesh": path.name,
                    "path": str(path),
                    "vertices": n_v,
                    "faces": n_f,
                    "size": size,
                    "repeats": repeats,
                    "remesh_seconds": remesh_times,
                    "remesh_median": remesh_med,
                    "floor_seconds": floor_times,
                    "floor_median": floor_med,
                    "floor_boundary": how,
                    "floor_boundary_count": len(b),
                    "ratio": remesh_med / floor_med,
                    "target_ratio": TARGET_RATIO,
                    "phases": phases,
                    "report": report,
                }
            )
    return rows


def print_results(machine: dict, rows: list[dict]) -> None:
    print("## Machine\n")
    print(f"- CPU: {machine['processor']}, os.cpu_count() = {machine['cpu_count']}")
    print(f"- OS: {machine['uname']}, Python {machine['python']}")
    print(f"- numpy {machine['numpy']}, libigl {machine['libigl']}, scipy {machine['scipy']}")
    print()
    print("## Remesh vs floor (median seconds)\n")
    print("| mesh | V | F | N | remesh s | floor s | ratio | target |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for r in rows:
        met = "met" if r["ratio"] <= r["target_ratio"] else "not met"
        print(
            f"| {r['mesh']} | {r['vertices']:,} | {r['faces']:,} | {r['size']} "
            f"| {r['remesh_median']:.2f} | {r['floor_median']:.2f} | {r['ratio']:.2f} "
            f"| ≤ {r['target_ratio']:g} ({met}) |"
        )
    print()
    print("Floor = read_mesh + one igl.harmonic(V, F, b, bc, 1); b per row:")
    for r in rows:
        print(f"- N={r['size']}: {r['floor_boundary']}")
    print()
    print("## Phase split of one extra remesh run (seconds)\n")
    print("| mesh | N | read | geometry image | to mesh | write | total |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        p = r["phases"]
        print(
            f"| {r['mesh']} | {r['size']} | {p['read']:.2f} | {p['geometry_image']:.2f} "
            f"| {p['to_mesh']:.2f} | {p['write']:.2f} | {p['total']:.2f} |"
        )
    print()
    print("## Report of that run\n")
    keys = [k for k in REPORT_KEYS if any(k in r["report"] for r in rows)]
    missing = [k for k in REPORT_KEYS if k not in keys]
    if keys:
        print("| mesh | N | " + " | ".join(keys) + " |")
        print("|---|---:|" + "---:|" * len(keys))
        for r in rows:
            cells = [str(r["report"].get(k, "n/a")) for k in keys]
            print(f"| {r['mesh']} | {r['size']} | " + " | ".join(cells) + " |")
    if missing:
        print(f"\n(not in the report: {', '.join(missing)})")


def _jsonable(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Time the remesh stage (read, geometry image, back to mesh, write) "
        "against read + one harmonic solve."
    )
    parser.add_argument(
        "--meshes",
        type=Path,
        default=DEFAULT_MESHES,
        help=f"directory whose largest *.ply (most faces) is benched (default {DEFAULT_MESHES})",
    )
    parser.add_argument("--mesh", type=Path, help="bench this file instead of the largest one")
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=[256, 512], help="grid sizes N (default 256 512)"
    )
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per figure (default 5)")
    parser.add_argument("--json", type=Path, help="also write the results as JSON to this file")
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    path = args.mesh if args.mesh is not None else largest_mesh(args.meshes)
    if not path.is_file():
        parser.error(f"no such mesh file: {path}")
    machine = machine_info("libigl", "scipy")
    rows = bench(path, args.sizes, args.repeats)
    print_results(machine, rows)
    if args.json is not None:
        payload = {"machine": machine, "rows": rows}
        args.json.write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n")
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
