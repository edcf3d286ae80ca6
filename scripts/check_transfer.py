"""Figures for meshwm.gim.transfer: a geometry-image change carried onto a mesh's own vertices.

For each mesh: a UV map (uv = xy on a synthetic sheet; igl.harmonic with the longest boundary
loop spread on the unit square's perimeter by arc length on a dev mesh), the sampling on the
N×N grid, a change field, the transfer; printed: V/N², coverage, the relative RMS of the
re-sampled change against the target on covered points, max |d| / max |change|, seconds.
Fields: ``low`` (three sinusoids of 1..4 cycles per axis), ``mid`` (Gaussian noise band-passed
to 8..16 cycles per side, roughly the level-3 wavelet band at N = 128), ``vertex`` (the
image of a smooth displacement of the vertices, sinusoids of their 3-D position, so the mesh
can carry it exactly; also printed: the RMS of d against that displacement, relative).
On a dev mesh the residual of ``low``/``mid`` is what the map lets the mesh carry: a cheap
harmonic map puts most of the square in a few large UV triangles, where no displacement of
three corners can follow the field.

    python scripts/check_transfer.py [--sizes 64 128 256] [--meshes plane_holes camelhead]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import igl
import numpy as np
import trimesh

from meshwm.gim.code import grid_faces
from meshwm.gim.sampling import grid_points, sampling_matrix
from meshwm.gim.transfer import ENERGIES, transfer_changes

MESHES = Path("/work/shared/meshes")


def sheet(k: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A k × k jittered, gently curved sheet with uv = xy."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    uv = np.stack([j.ravel(), i.ravel()], axis=1) / (k - 1)
    inner = ((i > 0) & (i < k - 1) & (j > 0) & (j < k - 1)).ravel()
    uv[inner] += rng.uniform(-0.3, 0.3, (int(inner.sum()), 2)) / (k - 1)
    z = 0.1 * np.sin(np.pi * uv[:, 0]) * np.sin(np.pi * uv[:, 1])
    return np.column_stack([uv, z]), grid_faces(k), uv


def square_harmonic(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The dev mesh and a harmonic map with its longest boundary loop on the square."""
    mesh = trimesh.load(MESHES / f"{name}.ply", process=False)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    loop = np.asarray(max(igl.boundary_loop_all(f), key=len), dtype=np.int64)
    step = np.linalg.norm(v[np.roll(loop, -1)] - v[loop], axis=1)
    t = 4.0 * np.concatenate([[0.0], np.cumsum(step)[:-1]]) / step.sum()  # 0..4 round the square
    side, s = np.floor(t).astype(int), t - np.floor(t)
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]])
    boundary = corners[side] + s[:, None] * (corners[side + 1] - corners[side])
    uv = igl.harmonic(v, f, loop, boundary, 1)
    return v, f, np.clip(uv, 0.0, 1.0)


def vertex_field(v: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A smooth (V, 3) displacement of max 1e-3: sinusoids of the positions (2 cycles/box)."""
    x = (v - v.min(axis=0)) / np.ptp(v, axis=0).max()
    out = np.stack(
        [np.sin(2 * np.pi * (x @ rng.normal(size=3)) + rng.uniform(0, 6)) for _ in range(3)], 1
    )
    return 1e-3 * out / np.abs(out).max()


def field(n: int, kind: str, rng: np.random.Generator) -> np.ndarray:
    """A change of unit max amplitude × 1e-3 on the (n, n, 3) grid."""
    if kind == "low":
        g = grid_points(n).reshape(n, n, 2)
        out = np.zeros((n, n, 3))
        for axis in range(3):
            for _ in range(3):
                fu, fv = rng.integers(1, 5, 2)
                pu, pv = rng.uniform(0, 2 * np.pi, 2)
                out[..., axis] += (
                    rng.normal()
                    * np.sin(2 * np.pi * fu * g[..., 0] + pu)
                    * np.cos(2 * np.pi * fv * g[..., 1] + pv)
                )
    else:
        spectrum = np.fft.fft2(rng.normal(size=(n, n, 3)), axes=(0, 1))
        k = np.fft.fftfreq(n) * n
        radius = np.hypot(k[:, None], k[None, :])
        band = (radius >= 8 * n / 128) & (radius <= 16 * n / 128)
        out = np.real(np.fft.ifft2(spectrum * band[..., None], axes=(0, 1)))
    return 1e-3 * out / np.abs(out).max()


def report(name, v, f, uv, n, kind, rng, smoothness, passes, energy) -> None:
    start = time.perf_counter()
    s = sampling_matrix(uv, f, n)
    t_sample = time.perf_counter() - start
    truth = vertex_field(v, rng) if kind == "vertex" else None
    change = field(n, kind, rng) if truth is None else (s.matrix @ truth).reshape(n, n, 3)
    start = time.perf_counter()
    d = transfer_changes(v, f, s, change, smoothness=smoothness, passes=passes, energy=energy)
    t_transfer = time.perf_counter() - start
    got = (s.matrix @ d).reshape(n, n, 3)[s.covered]
    want = change[s.covered]
    rel = np.sqrt(((got - want) ** 2).mean() / (want**2).mean())
    extra = ""
    if truth is not None:
        sampled = np.asarray(abs(s.matrix).sum(axis=0)).ravel() > 0
        miss = np.sqrt(((d - truth)[sampled] ** 2).mean() / (truth[sampled] ** 2).mean())
        extra = f" |d-truth|/|truth| (sampled vertices) {miss:.4f}"
    print(
        f"{name:12s} V={len(v):6d} N={n:3d} V/N²={len(v) / n / n:5.2f} "
        f"covered={s.covered.mean():.3f} {kind:3s} {energy} λ={smoothness:g} passes={passes} "
        f"relRMS={rel:.4f} max|d|/max|c|={np.abs(d).max() / np.abs(change).max():.3f} "
        f"sample {t_sample:.2f}s transfer {t_transfer:.2f}s{extra}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    parser.add_argument("--meshes", nargs="+", default=["sheet", "plane_holes", "camelhead"])
    parser.add_argument("--smoothness", type=float, nargs="+", default=[1e-2])
    parser.add_argument("--passes", type=int, default=3)
    parser.add_argument("--energy", default="bilaplacian", choices=sorted(ENERGIES))
    args = parser.parse_args()
    rng = np.random.default_rng(2026)
    for name in args.meshes:
        v, f, uv = sheet(64, rng) if name == "sheet" else square_harmonic(name)
        for n in args.sizes:
            for kind in ("low", "mid", "vertex"):
                for smoothness in args.smoothness:
                    report(name, v, f, uv, n, kind, rng, smoothness, args.passes, args.energy)


if __name__ == "__main__":
    main()
