"""Time the stable parameterisation (smoothed copy, canonical cut, Tutte map) against the floor.

For one mesh (default ``../shared/meshes/igea.ply``): ``read_mesh``, then phase by phase
:func:`meshwm.gim.stable.smoothed_copy`, :func:`meshwm.gim.stable.stable_cut` (which smooths
again, then labels, cuts and cuts open) and :func:`meshwm.gim.tutte.tutte_map`; against the
floor of ``scripts/bench_remesh.py`` (``read_mesh`` plus ONE ``igl.harmonic(V, F, b, bc, 1)``
with as many fixed vertices as the cut-open disk's boundary).  Medians over ``--repeats``.
Nothing is asserted: the script only prints figures.

    python scripts/bench_stable.py
    python scripts/bench_stable.py --mesh path/to/other.ply --repeats 5
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import igl
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from meshwm.gim.stable import stable_cut
from meshwm.gim.tutte import boundary_loop, tutte_map
from meshwm.mesh.io import read_mesh


def stable_once(path: Path) -> tuple[dict[str, float], int]:
    """One run from file to UVs; phase times and the disk's boundary length."""
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    t1 = time.perf_counter()
    cut = stable_cut(v, f)
    t2 = time.perf_counter()
    rank = np.empty_like(cut.order)
    rank[cut.order] = np.arange(len(cut.order))
    tutte_map(cut.mesh.faces, rank[cut.mesh.origin])
    t3 = time.perf_counter()
    n_border = len(boundary_loop(cut.mesh.faces, rank[cut.mesh.origin]))
    phases = {"read": t1 - t0, "cut": t2 - t1, "tutte": t3 - t2, "total": t3 - t0}
    return phases, n_border


def floor_once(path: Path, count: int) -> float:
    """``read_mesh`` plus one harmonic solve with ``count`` vertices fixed on a circle."""
    t0 = time.perf_counter()
    v, f = read_mesh(path)
    b = np.unique(np.linspace(0, len(v) - 1, count).round().astype(np.int64))
    angle = 2.0 * np.pi * np.arange(len(b)) / len(b)
    bc = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    igl.harmonic(np.ascontiguousarray(v), np.ascontiguousarray(f), b, bc, 1)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", type=Path, default=Path("../shared/meshes/igea.ply"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    phases, n_border = stable_once(args.mesh)  # warm-up
    runs = [stable_once(args.mesh)[0] for _ in range(args.repeats)]
    floors = [floor_once(args.mesh, n_border) for _ in range(args.repeats)]
    med = {k: statistics.median(r[k] for r in runs) for k in phases}
    floor = statistics.median(floors)
    print(f"{args.mesh.name}: boundary {n_border} vertices, medians of {args.repeats}")
    print("  " + "  ".join(f"{k} {t:.2f} s" for k, t in med.items()))
    print(f"  floor (read + 1 harmonic) {floor:.2f} s; stable / floor = {med['total'] / floor:.2f}")


if __name__ == "__main__":
    main()
