"""The interior map: a harmonic map of the disk onto the unit square, reweighted for stretch.

A harmonic map with cotangent weights clamped to be positive: with all weights positive and a
convex boundary, Tutte/Floater's theorem guarantees an embedding (no flipped triangle), which the
plain cotangent map does not on meshes with obtuse triangles.  The flipped count is still
measured and reported (:func:`meshwm.gim.remesh.mesh_to_geometry_image`).  The boundary is fixed
where :mod:`meshwm.gim.boundary` puts it; :func:`stretch_parameterize` then reweights the edges
to spread the grid samples over the surface, and :func:`grid_step` measures how far apart they
fall around each vertex.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._vector import _columns, face_area
from meshwm.gim.solve import solve_with_fixed

__all__ = ["GridStep", "flat_faces", "grid_step", "signed_uv_area", "stretch_parameterize"]

#: The relative residual of a large mesh's multigrid solves (:mod:`meshwm.gim.solve`; a smaller
#: mesh is solved directly): UVs to about 1e-7, a ten-thousandth of a sample at N = 1024; the
#: solves of the stretch reweighting start from the previous map.
_TOLERANCE = 1e-7

#: Faces at a time in the per-face passes (their gathered corners stay in the cache, and a
#: large mesh's temporaries stay small).
_CHUNK = 1 << 16


def _cotangents(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Half the cotangent of each face's angle at each corner, as ``igl.cotmatrix_entries``.

    Its arithmetic in its order, a chunk of faces and a coordinate at a time (the same bits):
    squared edge lengths ``l2[:, k]`` of the edge opposite corner ``k``, the doubled area by
    Kahan's formula on the sorted lengths (0 where it is NaN), ``(l2_j + l2_k - l2_i) / 2A / 4``.
    """
    columns = _columns(vertices)
    out = np.empty((len(faces), 3))
    with np.errstate(divide="ignore", invalid="ignore"):  # a zero area: igl's inf / NaN
        for lo in range(0, len(faces), _CHUNK):
            chunk = faces[lo : lo + _CHUNK]
            f = _columns(chunk)
            l2 = []
            for i, j in ((1, 2), (2, 0), (0, 1)):
                d = [column[f[i]] - column[f[j]] for column in columns]
                l2.append(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            length = np.sort(np.sqrt(np.stack(l2, axis=1)), axis=1)
            lc, lb, la = length[:, 0], length[:, 1], length[:, 2]  # la >= lb >= lc
            arg = (la + (lb + lc)) * (lc - (la - lb)) * (lc + (la - lb)) * (la + (lb - lc))
            double_area = 2.0 * 0.25 * np.sqrt(arg)
            double_area[np.isnan(double_area)] = 0.0
            rows = slice(lo, lo + len(chunk))
            out[rows, 0] = (l2[1] + l2[2] - l2[0]) / double_area / 4.0
            out[rows, 1] = (l2[2] + l2[0] - l2[1]) / double_area / 4.0
            out[rows, 2] = (l2[0] + l2[1] - l2[2]) / double_area / 4.0
    return out


def _laplacian_pattern(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray, NDArray, NDArray]:
    """Rows, columns and positive-clamped cotangent weights of the mesh Laplacian.

    The off-diagonal entries of ``igl.cotmatrix``, without its twelve triplets a face (10M
    faces: 9 s, 1.9 GB of them): bit for bit where each edge has at most two faces (a disk cut
    from a cleaned mesh), whose sum is one addition; an edge of more faces sums its terms in
    another order.
    """
    n = len(vertices)
    half = _cotangents(vertices, faces)
    index = np.int32 if n < np.iinfo(np.int32).max else np.int64
    f = np.asarray(faces, dtype=index)
    # Corner k's cotangent weighs the edge opposite it, (1, 2), (2, 0) and (0, 1).
    src = np.concatenate([f[:, 1], f[:, 2], f[:, 0], f[:, 2], f[:, 0], f[:, 1]])
    dst = np.concatenate([f[:, 2], f[:, 0], f[:, 1], f[:, 1], f[:, 2], f[:, 0]])
    del f
    value = np.tile(half.T.ravel(), 2)
    del half
    lap = sp.coo_matrix((value, (src, dst)), shape=(n, n)).tocsr().tocoo()
    del src, dst, value
    off = lap.row != lap.col  # a face with a repeated corner: igl's diagonal
    rows, cols, w = lap.row[off], lap.col[off], lap.data[off]
    floor = 1e-3 * np.median(np.abs(w))
    return rows, cols, np.maximum(w, floor)


def _solve_fixed_boundary(
    rows: NDArray,
    cols: NDArray,
    w: NDArray,
    boundary: NDArray,
    boundary_uv: NDArray,
    nv: int,
    guess: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """The weighted harmonic map with the boundary fixed (``guess``: the previous map, a
    start for the multigrid solve of a large mesh, :mod:`meshwm.gim.solve`)."""
    weights = sp.coo_matrix((w, (rows, cols)), shape=(nv, nv)).tocsr()
    degree = np.asarray(weights.sum(axis=1)).ravel()
    # Symmetric positive semi-definite; as CSR, the form the solve takes.
    q = sp.csr_matrix(sp.diags(degree) - weights)
    return solve_with_fixed(q, boundary, boundary_uv, guess=guess, tol=_TOLERANCE)


def _uv_area(s: list[NDArray[np.float64]], t: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Signed UV area of faces from their corners' coordinates ``s[k]``, ``t[k]``."""
    return 0.5 * ((s[1] - s[0]) * (t[2] - t[0]) - (t[1] - t[0]) * (s[2] - s[0]))


def _stretch_rows(
    columns: Sequence[NDArray[np.float64]],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    faces: NDArray[np.int64],
    flat: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """:func:`_face_stretch` of a chunk of faces, one coordinate column at a time."""
    f = _columns(faces)
    s = [u[k] for k in f]
    t = [v[k] for k in f]
    area_uv = _uv_area(s, t)
    # A triangle with all three corners on one side of the square has no UV area, whatever the
    # weights: it takes no part in the stretch (its samples come from the boundary chains).
    twice = 2 * np.where(flat | (area_uv == 0), 1.0, area_uv)
    ws = (t[1] - t[2], t[2] - t[0], t[0] - t[1])
    wt = (s[2] - s[1], s[0] - s[2], s[1] - s[0])
    sum_ds = sum_dt = np.zeros(0)
    for c, column in enumerate(columns):
        q = [column[k] for k in f]
        ds = (q[0] * ws[0] + q[1] * ws[1] + q[2] * ws[2]) / twice
        dt = (q[0] * wt[0] + q[1] * wt[1] + q[2] * wt[2]) / twice
        sum_ds = sum_ds + ds**2 if c else ds**2
        sum_dt = sum_dt + dt**2 if c else dt**2
    sigma = np.sqrt(0.5 * (sum_ds + sum_dt))
    sigma[flat] = 0.0
    return sigma


def _face_stretch(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    flat: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """Sander et al.'s L2 stretch of the map UV -> 3-D per face (0 on flat faces).

    ``sqrt((|ds|^2 + |dt|^2) / 2)`` with ``ds = (q1 (t2 - t3) + q2 (t3 - t1) + q3 (t1 - t2)) /
    (2 A)`` and ``dt`` likewise from ``s``, ``A`` the signed UV area, computed a chunk of faces
    and a coordinate at a time with the row-wise formula's operations in their order (the same
    bits without its (m, 3) gathers: 1.2 GB at 10M faces, at the grid mode's peak).
    """
    columns = _columns(vertices)
    u, v = np.ascontiguousarray(uv[:, 0]), np.ascontiguousarray(uv[:, 1])
    sigma = np.empty(len(faces))
    for lo in range(0, len(faces), _CHUNK):
        rows = slice(lo, lo + _CHUNK)
        sigma[rows] = _stretch_rows(columns, u, v, faces[rows], flat[rows])
    return sigma


def flat_faces(
    faces: NDArray[np.int64], boundary: NDArray[np.int64], boundary_uv: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Faces whose three corners are fixed on the same side of the square (zero UV area).

    Decided from the exact boundary positions, not from a computed area, so that it does not
    depend on rounding (which a rotated copy of the mesh would change).
    """
    nv = int(faces.max()) + 1
    sides = np.zeros((nv, 4), dtype=bool)
    u, v = boundary_uv[:, 0], boundary_uv[:, 1]
    sides[boundary] = np.stack([v == 0.0, u == 1.0, v == 1.0, u == 0.0], axis=1)
    return np.any(sides[faces[:, 0]] & sides[faces[:, 1]] & sides[faces[:, 2]], axis=1)


def stretch_parameterize(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    boundary: NDArray[np.int64],
    boundary_uv: NDArray[np.float64],
    *,
    iterations: int,
    good_enough: Callable[[NDArray[np.float64]], bool] | None = None,
    accept: Callable[[NDArray[np.float64]], bool] | None = None,
) -> tuple[NDArray[np.float64], list[float]]:
    """Harmonic map, then stretch-minimising reweighting (Yoshizawa, Belyaev, Seidel 2004).

    Starts from the harmonic map with positive-clamped cotangent weights (an embedding for a
    convex boundary, Floater 2003).  Each iteration divides every edge weight by the square of
    the mean L2 stretch (Sander et al. 2001) of its two end vertices and solves again; weights
    stay positive and symmetric, so each map is still an embedding.  A conformal map squeezes
    protrusions (a cow's legs) exponentially, which starves them of grid samples; this pulls UV
    area back to where the surface is.  Stops after ``iterations`` or when the global stretch
    no longer falls by 1 %, or as soon as ``good_enough(uv)`` holds, and returns the best map
    and the global stretch of each map.  If ``accept(uv)`` holds for the harmonic map itself,
    that map is returned as it is (a surface it already samples evenly needs no reweighting).
    """
    nv = len(vertices)
    flat = flat_faces(faces, boundary, boundary_uv)
    rows, cols, w = _laplacian_pattern(vertices, faces)
    uv = _solve_fixed_boundary(rows, cols, w, boundary, boundary_uv, nv)
    area3 = np.where(flat, 0.0, face_area(vertices, faces))
    if accept is not None and accept(uv):
        sigma = _face_stretch(vertices, faces, uv, flat)
        return uv, [float(np.sqrt((area3 * sigma**2).sum() / area3.sum()))]
    corner = faces.ravel()
    history: list[float] = []
    best = (np.inf, uv, w)
    power = 2.0
    for it in range(iterations + 1):
        sigma = _face_stretch(vertices, faces, uv, flat)
        total = float(np.sqrt((area3 * sigma**2).sum() / area3.sum()))
        history.append(total)
        if total < best[0]:
            improved = total < 0.99 * best[0]
            best = (total, uv, w)
        else:
            # Overshot: go back to the best weights and take a gentler step from there.
            improved = False
            power *= 0.5
            _, uv, w = best
            sigma = _face_stretch(vertices, faces, uv, flat)
        if it == iterations or (not improved and power < 0.25):
            break
        if improved and good_enough is not None and good_enough(uv):
            break
        num = np.bincount(corner, weights=np.repeat(area3 * sigma**2, 3), minlength=nv)
        den = np.bincount(corner, weights=np.repeat(area3, 3), minlength=nv)
        vertex_sigma = np.sqrt(num / np.maximum(den, np.finfo(float).tiny))
        typical = np.median(vertex_sigma[den > 0])
        # Bound each step's reweighting to six orders of magnitude: keeps the system well posed.
        vertex_sigma = np.clip(
            np.where(den > 0, vertex_sigma, typical), typical * 1e-3, typical * 1e3
        )
        w = w / (0.5 * (vertex_sigma[rows] + vertex_sigma[cols]) / typical) ** power
        w = np.clip(w / np.median(w), 1e-12, 1e12)
        uv = _solve_fixed_boundary(rows, cols, w, boundary, boundary_uv, nv, guess=uv)
    best_uv = best[1]
    return best_uv, history


def signed_uv_area(uv: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.float64]:
    """Signed area of each face in UV, positive for counter-clockwise.

    ``0.5 * ((b - a) x (c - a))`` over the corners' UV columns, a chunk of faces at a time.
    """
    u, v = np.ascontiguousarray(uv[:, 0]), np.ascontiguousarray(uv[:, 1])
    area = np.empty(len(faces))
    for lo in range(0, len(faces), _CHUNK):
        chunk = faces[lo : lo + _CHUNK]
        f = _columns(chunk)
        s = [u[k] for k in f]
        t = [v[k] for k in f]
        area[lo : lo + len(chunk)] = _uv_area(s, t)
    return area


class GridStep:
    """:func:`grid_step` for the many maps of one disk: its 3-D side computed once.

    Parameters are :func:`grid_step`'s but ``uv``; calling the object with ``uv`` gives the
    same bits as :func:`grid_step`.
    """

    def __init__(
        self,
        vertices: NDArray[np.float64],
        faces: NDArray[np.int64],
        origin: NDArray[np.int64],
        n_orig: int,
        graph: sp.csr_matrix,
        flat: NDArray[np.bool_],
    ) -> None:
        self._faces, self._origin, self._n = faces, origin, n_orig
        self._graph, self._flat = graph, flat
        self._area3 = self._two_ring(np.where(flat, 0.0, face_area(vertices, faces)))

    def _two_ring(self, per_face: NDArray[np.float64]) -> NDArray[np.float64]:
        corner = self._origin[self._faces].ravel()
        per_vertex = np.bincount(corner, weights=np.repeat(per_face, 3), minlength=self._n)
        # Built for each call, not kept: 0.4 GB at 5M vertices, alive through the solves.
        adj = self._graph.copy()
        adj.data[:] = 1.0
        adj = adj + sp.identity(self._n, format="csr")
        return adj @ (adj @ per_vertex)

    def __call__(self, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        auv = np.where(self._flat, 0.0, np.abs(signed_uv_area(uv, self._faces)))
        return np.sqrt(self._area3 / np.maximum(self._two_ring(auv), np.finfo(float).tiny))


def grid_step(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    origin: NDArray[np.int64],
    n_orig: int,
    graph: sp.csr_matrix,
    flat: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """Per original vertex: the 3-D length one UV unit spans, sqrt(3-D area / UV area).

    Areas are summed over each vertex's two-ring, so a single sliver does not decide.  Divided
    by N - 1 this is the spacing of the grid samples on the surface around the vertex.
    :class:`GridStep` does the same for many maps of one disk.
    """
    return GridStep(vertices, faces, origin, n_orig, graph, flat)(uv)
