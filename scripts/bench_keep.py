"""Cost of marking the user's own mesh against the floor: issue 13's speed target.

For each mesh, each timing in a fresh process with its imports done before the clock (median
of ``--repeat`` runs; in one process the second embedding of a mesh reuses what the first
computed of its connectivity, which a first embedding cannot):

- **floor**: reading the file (``meshwm.read_mesh``) plus one harmonic solve on the mesh with
  four fixed vertices, the least any blind map of the surface costs, two ways: libigl's
  (``igl.harmonic``, its simplicial sparse Cholesky) and meshwm's own solver
  (:func:`meshwm.gim.solve.solve_with_fixed` on libigl's cotangent matrix: CHOLMOD's
  supernodal Cholesky), the faster; the ratios are given to both;
- **embed**: ``meshwm.embed(..., ident=...)`` with the mesh kept, without the MeshLab distances
  (a report, not part of marking), plus the read;
- **extract**: reading the marked file and ``Decoder(...).extract_id(...)``.

Targets: embed ≤ 3× and extract ≤ 2× the floor on the largest development mesh (igea).

    python scripts/bench_keep.py [--meshes igea ...] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import igl
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from meshwm.gim.solve import solve_with_fixed
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.watermark import Decoder, embed

MESHES = Path(__file__).resolve().parents[2] / "shared" / "meshes"
IDENT = bytes.fromhex("0badc0de5ca1ab1e")


def _floor(path: Path) -> float:
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    igl.harmonic(v, f, np.arange(4), np.eye(4)[:, :2], 1)
    return time.perf_counter() - t0


def _floor_own(path: Path) -> float:
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    solve_with_fixed(-igl.cotmatrix(v, f), np.arange(4), np.eye(4)[:, :2])
    return time.perf_counter() - t0


def _embed(path: Path, out: Path) -> float:
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    marked = embed(v, f, key="bench", ident=IDENT, distances=False)
    elapsed = time.perf_counter() - t0
    write_mesh(out, marked.vertices, marked.faces)
    return elapsed


def _extract(path: Path) -> float:
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    found = Decoder(v, f).extract_id(key="bench")
    elapsed = time.perf_counter() - t0
    if found.id != IDENT.hex():
        raise SystemExit(f"{path}: the id did not read back ({found.id})")
    return elapsed


def _fresh(what: str, path: Path, out: Path) -> float:
    """One timing in a fresh process (the parent reads it from stdout)."""
    cmd = [sys.executable, __file__, "--child", what, str(path), str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{what} {path}: {done.stderr.strip().splitlines()[-1:]}")
    return float(done.stdout.strip().splitlines()[-1])


def _child(what: str, path: Path, out: Path) -> None:
    run = {"floor": _floor, "floor_own": _floor_own, "embed": _embed, "extract": _extract}[what]
    print(run(out) if what == "extract" else run(path, out) if what == "embed" else run(path))


def main() -> None:
    if len(sys.argv) == 5 and sys.argv[1] == "--child":
        # The memory settings `meshwm`'s command line makes for itself (meshwm/_malloc.py).
        from meshwm._malloc import keep_freed_memory

        keep_freed_memory(until_exit=True)
        _child(sys.argv[2], Path(sys.argv[3]), Path(sys.argv[4]))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=["igea"])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(
        "| mesh | vertices | floor s (libigl / own) | embed s | × floor (libigl / own) "
        "| extract s | × floor (libigl / own) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.meshes:
            path = MESHES / f"{name}.ply"
            out = Path(tmp) / f"{name}.ply"
            floor, own, emb, ext = [], [], [], []
            for _ in range(args.repeat):  # interleaved, so a load spike hits all alike
                floor.append(_fresh("floor", path, out))
                own.append(_fresh("floor_own", path, out))
                emb.append(_fresh("embed", path, out))
                ext.append(_fresh("extract", path, out))
            fl, fo, em, ex = (statistics.median(x) for x in (floor, own, emb, ext))
            n = len(read_mesh(path)[0])
            print(
                f"| {name} | {n} | {fl:.2f} / {fo:.2f} | {em:.2f} | {em / fl:.2f} / {em / fo:.2f} "
                f"| {ex:.2f} | {ex / fl:.2f} / {ex / fo:.2f} |"
            )


if __name__ == "__main__":
    main()
