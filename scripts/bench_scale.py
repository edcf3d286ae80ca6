"""Cost against mesh size: issue 16's linear-time targets, in both modes.

One development mesh (igea, 134k vertices) refined to about 0.1M, 0.5M, 2M and 5M vertices
(as it is; Loop-subdivided once; twice; decimated to 78k vertices and Loop-subdivided three
times), made in a cache folder (a temporary one by default), never committed.  Every
measurement runs in a fresh process (wall time of the whole operation, reading the file
included, and the process's peak resident memory):

- **floor**: reading the file, a cut to a disk and one harmonic solve.  Measured four ways:
  libigl's (``igl.cut_to_disk`` on the mesh, ``igl.harmonic`` with four fixed vertices, its
  sparse Cholesky) up to 2M vertices; a breadth-first tree cut and one cotangent-Laplacian
  solve with the same four vertices fixed by meshwm's own solver (:mod:`meshwm.gim.solve`:
  CHOLMOD's supernodal Cholesky up to 600k unknowns, multigrid above), the fastest, the
  *floor*; the same by multigrid at every size, whose cost is linear in the mesh where the
  factorisation's is not, the *linear floor* (the issue asks a super-linear piece of the
  floor replaced by a linear one); and, for reference, the solve with uniform weights (the
  graph Laplacian, what the kept mode's Tutte map solves).  Embeddings get both ratios;
- **kept**: ``meshwm.embed(v, f, key=..., ident=..., distances=False)`` (the user's mesh kept),
  then reading the marked file and ``Decoder(...).extract_id``;
- **grid N**: the same with ``grid=True`` at N = 256 and 1024.

The median of ``--repeat`` runs up to 0.5M vertices, single runs above; the log-log slope of
time against vertices from the first size to the last.  ``--throughput``: ``meshwm verify`` on
200 marked files of about 50k vertices per mode (one marked mesh, moved by 200 random
similarities), ``--jobs 1`` and ``2``, against reading the same files.

    python scripts/bench_scale.py [--sizes 0.1 0.5 2 5] [--repeat 3] [--timeout 1800]
        [--cache DIR] [--out docs/bench/scale.md] [--throughput]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

MESHES = ROOT.parent / "shared" / "meshes"
IDENT = bytes.fromhex("0badc0de5ca1ab1e")
KEY = "bench-scale"
MAX_FACES = 20_000_000
#: The operations measured, each in its own process.
RUNS = ("floor", "kept", "grid256", "grid1024")


# -- the meshes ---------------------------------------------------------------------------


def _meshlab(vertices, faces, name: str, **options):  # type: ignore[no-untyped-def]
    """One MeshLab filter applied to a mesh: its new vertices and faces."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertices, faces))
    getattr(ms, name)(**options)
    m = ms.current_mesh()
    return m.vertex_matrix(), m.face_matrix()


def _loop(vertices, faces):  # type: ignore[no-untyped-def]
    import pymeshlab

    threshold = pymeshlab.PercentageValue(0)
    return _meshlab(
        vertices, faces, "meshing_surface_subdivision_loop", iterations=1, threshold=threshold
    )


def _decimate(vertices, faces, count: int):  # type: ignore[no-untyped-def]
    return _meshlab(
        vertices,
        faces,
        "meshing_decimation_quadric_edge_collapse",
        targetfacenum=2 * count,
        preservetopology=True,
    )


def make_meshes(cache: Path, sizes: list[float]) -> dict[float, Path]:
    """igea refined to about each size (millions of vertices), written to ``cache``.

    Every size is Loop subdivision of igea, k times (each about 4× the vertices), k the fewest
    with ``size / 4^k`` at most 1.2 times igea's 134,345 vertices: igea itself where that is at
    least 0.65 times them (0.1M, 0.5M, 2M), else igea first decimated to ``size / 4^k`` (5M:
    78,125 vertices, three steps).  So every mesh is of one kind: until 2026-12-04 the 5M
    mesh was the 2M one with its longest edges split, whose valence-4 vertices and needles
    multigrid coarsens worse (docs/bench/scale.md).
    """
    from meshwm.mesh.io import read_mesh, write_mesh

    out: dict[float, Path] = {}
    v0, f0 = read_mesh(MESHES / "igea.ply")
    for size in sorted(sizes):
        target = 1e6 * size
        k = 0
        while target / 4**k > 1.2 * len(v0):
            k += 1
        decimated = target / 4**k < 0.65 * len(v0)
        path = cache / f"igea_{size:g}M{'_decimated' if decimated else ''}.ply"
        out[size] = path
        if path.exists():
            continue
        v, f = _decimate(v0, f0, round(target / 4**k)) if decimated else (v0, f0)
        for _ in range(k):
            v, f = _loop(v, f)
        write_mesh(path, v, f)
    return out


# -- one measurement per process ----------------------------------------------------------


def _child(what: str, mesh: str, work: str) -> dict:
    """Run one operation and return its figures (the parent reads them from stdout)."""
    import numpy as np

    from meshwm.mesh.io import read_mesh, write_mesh
    from meshwm.params import WatermarkParams
    from meshwm.watermark import Decoder, embed

    # Imports before the clock, as the floor's are (importing the watermark stack took
    # 0.4-0.5 s, inside every embed and extract time before 2026-12-04).
    t0 = time.perf_counter()
    figures: dict = {}
    if what in ("floor", "floor_igl"):
        v, f = read_mesh(mesh, max_faces=MAX_FACES)
        figures["read"] = time.perf_counter() - t0
        figures.update(_floor_pieces(v, f, igl_pieces=what == "floor_igl"))
    elif what.startswith("embed"):
        v, f = read_mesh(mesh, max_faces=MAX_FACES)
        grid = what != "embed_kept"
        params = WatermarkParams(size=int(what[len("embed_grid") :])) if grid else None
        marked = embed(
            v,
            f,
            key=KEY,
            ident=IDENT,
            distances=False,
            grid=grid,
            params=params,
            max_faces=MAX_FACES,
        )
        figures["seconds"] = time.perf_counter() - t0
        write_mesh(work, marked.vertices, marked.faces)
        figures["vertices_out"] = len(marked.vertices)
    else:
        v, f = read_mesh(work, max_faces=MAX_FACES)
        found = Decoder(v, f, max_faces=MAX_FACES).extract_id(key=KEY)
        figures["seconds"] = time.perf_counter() - t0
        figures["read_back"] = found.id == IDENT.hex()
    figures["seconds"] = figures.get("seconds", time.perf_counter() - t0)
    figures["peak_gb"] = _peak_gb()
    np.asarray(0)
    return figures


def _peak_gb() -> float:
    """This process's peak resident memory, GB.

    ``VmHWM`` of ``/proc/self/status``, the high-water mark of this program's own memory:
    ``getrusage``'s ``ru_maxrss`` survives ``exec`` on Linux, so a child started by a parent
    that held a 5M-vertex mesh would report the parent's peak.
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 2**20  # kB
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def _floor_pieces(v, f, *, igl_pieces: bool) -> dict:  # type: ignore[no-untyped-def]
    """The cut and the harmonic solve of the floor, timed apart."""
    import igl
    import numpy as np
    import scipy.sparse as sp
    from scipy.sparse.csgraph import breadth_first_order

    from meshwm.gim.solve import solve_with_fixed

    out = {}
    fixed = np.arange(4)
    values = np.eye(4)[:, :2]
    if igl_pieces:
        t = time.perf_counter()
        igl.cut_to_disk(f)
        out["cut_igl"] = time.perf_counter() - t
        t = time.perf_counter()
        igl.harmonic(v, f, fixed, values, 1)
        out["harmonic_igl"] = time.perf_counter() - t
        return out
    t = time.perf_counter()
    n = len(v)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    graph = sp.csr_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    order, parent = breadth_first_order(graph, 0, directed=False)
    path = [int(order[-1])]
    while parent[path[-1]] >= 0:
        path.append(int(parent[path[-1]]))
    out["cut_bfs"] = time.perf_counter() - t
    t = time.perf_counter()
    solve_with_fixed(-igl.cotmatrix(v, f), fixed, values)
    out["harmonic_amg"] = time.perf_counter() - t
    t = time.perf_counter()
    solve_with_fixed(-igl.cotmatrix(v, f), fixed, values, solver="multigrid")
    out["harmonic_mg"] = time.perf_counter() - t
    # The same solve with uniform weights (the graph Laplacian D - A, what the kept mode's
    # Tutte map solves): an M-matrix, where the cotangent weights of obtuse triangles are
    # negative.  (Measured, it grows as fast: not the weights; docs/bench/scale.md.)
    t = time.perf_counter()
    a = sp.csr_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    a = ((a + a.T) > 0).astype(np.float64)
    laplacian = sp.diags(np.asarray(a.sum(axis=1)).ravel()) - a
    solve_with_fixed(sp.csc_matrix(laplacian), fixed, values)
    out["harmonic_uniform"] = time.perf_counter() - t
    return out


def _run(what: str, mesh: Path, work: Path, timeout: float) -> dict | None:
    """One operation in a fresh process; None if it failed or ran out of time."""
    cmd = [sys.executable, __file__, "--child", what, str(mesh), str(work)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"timeout": timeout}
    if done.returncode != 0:
        return {"error": (done.stderr.strip().splitlines() or ["?"])[-1]}
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


# -- the tables ---------------------------------------------------------------------------


def _fmt(x: float | None, digits: int = 1) -> str:
    return "–" if x is None else f"{x:.{digits}f}"


def _median(runs: list[dict], field: str) -> float | None:
    values = [r[field] for r in runs if r and field in r]
    return statistics.median(values) if values else None


def _slope(points: list[tuple[int, float]]) -> float | None:
    points = [(n, t) for n, t in points if t]
    if len(points) < 2:
        return None
    (n0, t0), (n1, t1) = points[0], points[-1]
    return math.log(t1 / t0) / math.log(n1 / n0)


def measure(args: argparse.Namespace, cache: Path, out: Path) -> None:
    from meshwm.mesh.io import read_mesh

    meshes = make_meshes(cache, args.sizes)
    lines = [
        "| mesh | vertices | run | embed s | × floor | × linear floor | embed peak GB "
        "| extract s | × floor | extract peak GB | reads |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    floors = [
        "| vertices | read s | BFS cut s | harmonic s | floor s | multigrid harmonic s "
        "| linear floor s | uniform harmonic s | peak GB | igl cut_to_disk s | igl harmonic s |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    series: dict[str, list[tuple[int, float]]] = {}
    for size in sorted(args.sizes):
        mesh = meshes[size]
        n = len(read_mesh(mesh, max_faces=MAX_FACES)[0])
        repeat = args.repeat if size <= 0.5 else 1
        results: dict[str, list[dict]] = {k: [] for k in RUNS}
        extracts: dict[str, list[dict]] = {k: [] for k in RUNS}
        for _ in range(repeat):  # interleaved, so a load spike hits every column alike
            for run in RUNS:
                if run not in args.runs:
                    continue
                if run == "floor":
                    results[run].append(_run("floor", mesh, mesh, args.timeout) or {})
                    continue
                work = cache / f"marked_{size:g}_{run}.ply"
                what = "embed_kept" if run == "kept" else f"embed_grid{run[4:]}"
                results[run].append(_run(what, mesh, work, args.timeout) or {})
                if results[run][-1].get("seconds") is not None:
                    extracts[run].append(_run("extract", mesh, work, args.timeout) or {})
        igl_floor = _run("floor_igl", mesh, mesh, args.timeout) if size <= 2 else None
        fl = results["floor"]
        parts = [_median(fl, k) for k in ("read", "cut_bfs", "harmonic_amg")]
        floor = sum(parts) if all(p is not None for p in parts) else None  # type: ignore[misc]
        multigrid = _median(fl, "harmonic_mg")
        l_floor = floor - parts[2] + multigrid if floor and multigrid else None  # type: ignore[operator]
        floors.append(
            f"| {n:,} | {_fmt(parts[0], 2)} | {_fmt(parts[1], 2)} | {_fmt(parts[2], 2)} "
            f"| {_fmt(floor, 2)} | {_fmt(multigrid, 2)} | {_fmt(l_floor, 2)} "
            f"| {_fmt(_median(fl, 'harmonic_uniform'), 2)} | {_fmt(_median(fl, 'peak_gb'), 2)} "
            f"| {_fmt((igl_floor or {}).get('cut_igl'), 2)} "
            f"| {_fmt((igl_floor or {}).get('harmonic_igl'), 2)} |"
        )
        series.setdefault("floor", []).append((n, floor or 0.0))
        series.setdefault("linear floor", []).append((n, l_floor or 0.0))
        for run in RUNS[1:]:
            if run not in args.runs:
                continue
            emb, ext = results[run], extracts[run]
            e_s, x_s = _median(emb, "seconds"), _median(ext, "seconds")
            failed = [r for r in emb + ext if "seconds" not in r]
            note = "; ".join(
                f"timeout {r['timeout']:.0f} s" if "timeout" in r else str(r.get("error"))[:80]
                for r in failed
            )
            reads = f"{sum(bool(r.get('read_back')) for r in ext)}/{len(ext)}"
            lines.append(
                f"| igea {size:g}M | {n:,} | {run} | {_fmt(e_s)} "
                f"| {_fmt(e_s / floor if e_s and floor else None, 2)} "
                f"| {_fmt(e_s / l_floor if e_s and l_floor else None, 2)} "
                f"| {_fmt(_median(emb, 'peak_gb'), 2)} | {_fmt(x_s)} "
                f"| {_fmt(x_s / floor if x_s and floor else None, 2)} "
                f"| {_fmt(_median(ext, 'peak_gb'), 2)} | {reads}{' ' + note if note else ''} |"
            )
            series.setdefault(f"{run} embed", []).append((n, e_s or 0.0))
            series.setdefault(f"{run} extract", []).append((n, x_s or 0.0))
        _write(out, args, floors, lines, series)
        print(lines[-1], flush=True)


def _write(out: Path, args: argparse.Namespace, floors, lines, series) -> None:  # type: ignore[no-untyped-def]
    load = os.getloadavg()
    slopes = ["| series | slope (log time / log vertices, first to last size) |", "|---|---:|"]
    slopes += [f"| {k} | {_fmt(_slope(v), 3)} |" for k, v in series.items()]
    text = "\n".join(
        [
            "# Cost against mesh size (issue 16)",
            "",
            f"`python scripts/bench_scale.py --sizes {' '.join(f'{s:g}' for s in args.sizes)} "
            f"--repeat {args.repeat}` (load average at writing: "
            f"{load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on 2 cores, shared).",
            "",
            "## The floor: read + cut + one harmonic solve",
            "",
            *floors,
            "",
            "## Embed and extract",
            "",
            *lines,
            "",
            "## Slopes",
            "",
            *slopes,
            "",
        ]
    )
    out.write_text(text)


# -- throughput ---------------------------------------------------------------------------


def throughput(cache: Path, count: int) -> list[str]:
    """``meshwm verify`` files per second per core on ``count`` marked files per mode."""
    import numpy as np
    import pymeshlab

    from meshwm.mesh.io import read_mesh, write_mesh
    from meshwm.params import WatermarkParams
    from meshwm.watermark import embed

    base = cache / "igea_50k.ply"
    if not base.exists():
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(*read_mesh(MESHES / "igea.ply")))
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=100_000)
        m = ms.current_mesh()
        write_mesh(base, m.vertex_matrix(), m.face_matrix())
    v, f = read_mesh(base)
    rows = [
        "| mode | files | vertices | jobs | verify s | files/s/core | read s | × read | detected |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for mode in ("kept", "grid"):
        folder = cache / f"assets_{mode}"
        if not folder.exists():
            params = WatermarkParams(size=256) if mode == "grid" else None
            marked = embed(
                v, f, key=KEY, ident=IDENT, distances=False, grid=mode == "grid", params=params
            )
            folder.mkdir()
            rng = np.random.default_rng(16)
            for i in range(count):
                q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
                moved = rng.uniform(0.5, 2.0) * marked.vertices @ q.T + rng.uniform(-10, 10, 3)
                write_mesh(folder / f"asset_{i:03d}.ply", moved, marked.faces)
        n_vertices = len(read_mesh(folder / "asset_000.ply")[0])
        for jobs in (1, 2):
            t = time.perf_counter()
            read = subprocess.run(
                [sys.executable, __file__, "--read-all", str(folder), str(jobs)],
                capture_output=True,
                text=True,
                check=True,
            )
            read_s = float(read.stdout.strip().splitlines()[-1])
            t = time.perf_counter()
            verify = [sys.executable, "-m", "meshwm", "verify", "--id", "0x" + IDENT.hex()]
            done = subprocess.run(
                [*verify, "--key", KEY, "--jobs", str(jobs), "--jsonl", str(folder)],
                capture_output=True,
                text=True,
                check=False,
                cwd=ROOT,
            )
            verify_s = time.perf_counter() - t
            if done.returncode == 2:  # an error, not a verdict: no figure to print
                raise SystemExit(f"verify failed: {done.stderr.strip()}")
            found = sum('"detected": true' in line for line in done.stdout.splitlines())
            rows.append(
                f"| {mode} | {count} | {n_vertices:,} | {jobs} | {verify_s:.1f} "
                f"| {count / verify_s / jobs:.2f} | {read_s:.1f} | {verify_s / read_s:.1f} "
                f"| {found}/{count} |"
            )
            print(rows[-1], flush=True)
    return rows


def _read_all(folder: str, jobs: int) -> float:
    from concurrent.futures import ProcessPoolExecutor

    from meshwm.mesh.io import read_mesh

    files = sorted(Path(folder).glob("*.ply"))
    t = time.perf_counter()
    with ProcessPoolExecutor(jobs) as pool:
        list(pool.map(read_mesh, files, chunksize=8))
    return time.perf_counter() - t


def _compile_package() -> None:
    """Byte-compile meshwm's modules, as ``pip install`` does (a package imported from a source
    tree with ``PYTHONDONTWRITEBYTECODE`` set compiles a module it imports inside a timed
    operation every time: 0.02-0.04 s of a 134k-vertex embedding, none of the floor's)."""
    import compileall

    import meshwm

    compileall.compile_dir(Path(meshwm.__file__).parent, quiet=1)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        # The memory settings `meshwm`'s command line makes for itself (meshwm/_malloc.py),
        # for every operation (the floor too): memory kept until the process exits.
        from meshwm._malloc import keep_freed_memory

        keep_freed_memory(until_exit=True)
        print(json.dumps(_child(*sys.argv[2:5])))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--read-all":
        print(_read_all(sys.argv[2], int(sys.argv[3])))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.1, 0.5, 2, 5])
    parser.add_argument("--runs", nargs="+", default=list(RUNS), choices=RUNS)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--timeout", type=float, default=1800.0)
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "bench" / "scale.md")
    parser.add_argument("--throughput", action="store_true", help="only the 200-file check")
    parser.add_argument("--files", type=int, default=200)
    args = parser.parse_args()
    _compile_package()
    with tempfile.TemporaryDirectory() as tmp:
        cache = args.cache or Path(tmp)
        cache.mkdir(parents=True, exist_ok=True)
        if args.throughput:
            rows = throughput(cache, args.files)
            with args.out.open("a") as fh:
                fh.write("\n## Throughput: verify on marked files\n\n" + "\n".join(rows) + "\n")
            return
        measure(args, cache, args.out)


if __name__ == "__main__":
    main()
