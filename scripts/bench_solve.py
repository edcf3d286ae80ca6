"""The sparse solvers meshwm could use, on the systems it solves: which is fastest at each size.

For each mesh, two systems (each solver in a fresh process: wall time and the process's peak
resident memory):

- **tutte**: the uniform graph Laplacian of the mesh's edges with four vertices fixed (the shape
  of the Tutte map's system, :func:`meshwm.gim.tutte.tutte_map`), two right-hand sides;
- **transfer** (``--transfer``): the embedder's normal equations ``SᵀS + μR + εI`` at N = 128
  (:class:`meshwm.gim.transfer.Transfer`), three right-hand sides.

Solvers: libigl's simplicial Cholesky (``igl.min_quad_with_fixed``), CHOLMOD's supernodal
Cholesky (through CVXOPT) and PyAMG's smoothed aggregation with conjugate gradients to a
relative residual of 1e-10 (:mod:`meshwm.gim.solve`).  The numbers behind
:data:`meshwm.gim.solve.DIRECT_LIMIT`.

    python scripts/bench_solve.py MESH.ply ... [--transfer] [--solvers igl cholmod amg]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SOLVERS = ("igl", "cholmod", "amg")


def _system(path: str, which: str) -> tuple[sp.csc_matrix, np.ndarray]:
    """The free block and right-hand side of ``which`` on the mesh at ``path``."""
    from meshwm.gim.transfer import ENERGIES, uniform_laplacian
    from meshwm.mesh.edges import unique_edges
    from meshwm.mesh.io import read_mesh

    v, f = read_mesh(path)
    if which == "tutte":
        n = len(v)
        edges, _ = unique_edges(f)
        adjacency = sp.coo_matrix(
            (np.ones(2 * len(edges)), (edges.T.ravel(), edges[:, ::-1].T.ravel())), shape=(n, n)
        ).tocsr()
        laplacian = (sp.diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency).tocsr()
        free = np.arange(4, n)
        rhs = -np.asarray(laplacian[free][:, :4] @ np.eye(4)[:, :2])
        return sp.csc_matrix(laplacian[free][:, free]), rhs
    from meshwm.gim.surface import sample_surface, surface_of

    surface = surface_of(v, f, max_faces=50_000_000)
    image = sample_surface(surface, size=128)
    data = sp.csr_matrix(image.matrix[image.covered.ravel()])
    n = len(surface.positions)
    lap = uniform_laplacian(surface.faces, n)
    normal = data.T @ data + 1e-2 * data.shape[0] / n * ENERGIES["dirichlet"](lap)
    normal = normal + 1e-10 * normal.diagonal().mean() * sp.identity(n)
    rhs = np.random.default_rng(0).normal(size=(n, 3))
    return sp.csc_matrix(normal), rhs


def one(path: str, which: str, solver: str) -> dict:
    """Build the system, then time the solve alone (factorisation or hierarchy included)."""
    import igl

    from meshwm.gim import solve

    matrix, rhs = _system(path, which)
    t0 = time.perf_counter()
    if solver == "igl":
        data = igl.min_quad_with_fixed_data()
        n = matrix.shape[0]
        igl.min_quad_with_fixed_precompute(
            matrix, np.zeros(0, dtype=np.int64), sp.csc_matrix((0, n)), True, data
        )
        none = np.zeros((0, rhs.shape[1]))
        x = np.asarray(igl.min_quad_with_fixed_solve(data, -rhs, none, none))
    elif solver == "cholmod":
        x = solve._Cholesky(matrix).solve(rhs)
    else:
        hierarchy = solve._hierarchy(sp.csr_matrix(matrix))
        x = solve._amg_solve(hierarchy, rhs, guess=None, tol=1e-10, maxiter=400)
    seconds = time.perf_counter() - t0
    residual = float(np.linalg.norm(matrix @ x - rhs) / np.linalg.norm(rhs))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return {"n": matrix.shape[0], "seconds": seconds, "peak_gb": peak, "residual": residual}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="*")
    parser.add_argument("--transfer", action="store_true")
    parser.add_argument("--solvers", nargs="+", choices=SOLVERS, default=list(SOLVERS))
    parser.add_argument("--one", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one(*args.one)))
        return
    if not args.meshes:
        parser.error("give at least one mesh")
    missing = [m for m in args.meshes if not Path(m).is_file()]
    if missing:
        parser.error(f"no such mesh file: {missing[0]}")
    print("| mesh | system | unknowns | solver | seconds | peak GB | residual |")
    print("|---|---|---:|---|---:|---:|---:|")
    for mesh in args.meshes:
        for which in ("tutte", "transfer") if args.transfer else ("tutte",):
            for solver in args.solvers:
                run = subprocess.run(
                    [sys.executable, __file__, "--one", mesh, which, solver],
                    capture_output=True,
                    text=True,
                )
                if run.returncode:
                    print(f"| {Path(mesh).stem} | {which} | | {solver} | failed | | |")
                    continue
                r = json.loads(run.stdout.strip().splitlines()[-1])
                print(
                    f"| {Path(mesh).stem} | {which} | {r['n']:,} | {solver} | {r['seconds']:.2f} "
                    f"| {r['peak_gb']:.2f} | {r['residual']:.1e} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
