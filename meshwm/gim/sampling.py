"""The sparse barycentric sampling matrix of a parameterised mesh on the N×N grid.

A mesh with a map ``uv`` of its own vertices into the unit square is sampled at the grid points
``(u, v) = (j, i) / (N - 1)``: each grid point is located in the UV triangle that contains it and
takes the barycentric combination of that triangle's three vertices.  The weights form one sparse
``(N², V)`` matrix ``S``, so ``S @ vertices`` is the geometry image of the mesh under the map and
``S @ d`` is what a vertex displacement ``d`` does to it (:mod:`meshwm.transfer` inverts that).
Unlike :mod:`meshwm.gim.sample` nothing is snapped or clamped: a grid point outside every UV
triangle is left out (an empty row, ``covered`` False).
"""

from __future__ import annotations

from typing import NamedTuple

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm._validate import check_integer

__all__ = [
    "Sampling",
    "bilinear_matrix",
    "grid_points",
    "locate_grid_points",
    "near_grid_faces",
    "sampling_matrix",
]


class Sampling(NamedTuple):
    """The sampling of a mesh's vertices on the N×N grid.

    Attributes
    ----------
    matrix : (N², V) scipy.sparse.csr_matrix of float64
        Row ``i * N + j`` holds the barycentric weights (at most 3, summing to 1) of the grid
        point ``(u, v) = (j, i) / (N - 1)`` in the UV triangle that contains it; empty where the
        point is not covered.
    covered : (N, N) bool ndarray
        ``covered[i, j]``: the grid point lies in (or within ``tolerance`` of) a UV triangle.
    """

    matrix: sp.csr_matrix
    covered: NDArray[np.bool_]


def grid_points(n: int) -> NDArray[np.float64]:
    """The ``(N², 2)`` grid points in row-major order: row ``i * N + j`` is ``(j, i) / (N - 1)``.

    Examples
    --------
    >>> grid_points(2).tolist()
    [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
    """
    g = np.arange(n, dtype=np.float64) / (n - 1)
    uu, vv = np.meshgrid(g, g)  # uu[i, j] = j / (N - 1), vv[i, j] = i / (N - 1)
    return np.stack([uu.ravel(), vv.ravel()], axis=1)


def bilinear_matrix(uv: NDArray[np.float64], n: int) -> sp.csr_matrix:
    """The bilinear weights of points of the unit square on the N×N grid points.

    The transpose of the geometry image's sampling: where :func:`sampling_matrix` reads grid
    points off a mesh, this reads points (a mesh's vertices, at their UVs) off a grid, so
    ``bilinear_matrix(uv, n) @ image.reshape(N², k)`` is the image's bilinear interpolant at
    ``uv``.

    Parameters
    ----------
    uv : (V, 2) array_like of float
        Points, normally in ``[0, 1]²``; outside it they take the nearest cell's weights
        (extrapolated, still summing to 1).
    n : int
        Grid size N >= 2.

    Returns
    -------
    (V, N²) scipy.sparse.csr_matrix of float64
        Row ``k`` holds at most four weights, summing to 1, at the corners ``i * N + j`` of the
        cell that holds ``uv[k]``.

    Raises
    ------
    ValueError
        ``uv`` not (V, 2) or not finite, ``n`` < 2.

    Examples
    --------
    >>> m = bilinear_matrix(np.array([[0.25, 0.5], [1.0, 1.0]]), 3)
    >>> m.toarray().round(3).tolist()[0]
    [0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0]
    >>> (m @ grid_points(3)).tolist()  # a linear field is reproduced
    [[0.25, 0.5], [1.0, 1.0]]
    """
    size = check_integer(n, name="n", low=2)
    u = np.asarray(uv, dtype=np.float64)
    if u.ndim != 2 or u.shape[1] != 2:
        raise ValueError(f"uv must have shape (V, 2), got {u.shape}")
    if not np.isfinite(u).all():
        raise ValueError("uv must be finite")
    scaled = u * (size - 1)
    cell = np.clip(np.floor(scaled), 0, size - 2).astype(np.int64)
    frac = scaled - cell
    fx, fy = frac[:, 0], frac[:, 1]
    corner = cell[:, 1] * size + cell[:, 0]  # row i = v, column j = u
    cols = np.stack([corner, corner + 1, corner + size, corner + size + 1], axis=1)
    weights = np.stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy], axis=1)
    rows = np.repeat(np.arange(len(u)), 4)
    matrix = sp.csr_matrix((weights.ravel(), (rows, cols.ravel())), shape=(len(u), size * size))
    matrix.eliminate_zeros()
    return matrix


def _check_inputs(uv: object, faces: object, n: object) -> tuple[NDArray, NDArray, int]:
    """Validate and normalise the inputs of :func:`sampling_matrix`."""
    size = check_integer(n, name="n", low=2)
    u = np.asarray(uv)
    if u.ndim != 2 or u.shape[1] != 2 or len(u) == 0:
        raise ValueError(f"uv must have shape (V, 2) with V >= 1, got {u.shape}")
    if not np.issubdtype(u.dtype, np.number) or np.iscomplexobj(u):
        raise ValueError(f"uv must hold real numbers, got dtype {u.dtype}")
    u = u.astype(np.float64)
    bad = ~np.isfinite(u).all(axis=1)
    if bad.any():
        raise ValueError(
            f"uv has NaN or infinite entries at {int(bad.sum())} vertices "
            f"(first: {int(np.argmax(bad))})"
        )
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise ValueError(f"faces must be triangles with shape (F, 3), F >= 1, got {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"faces must hold integer indices, got dtype {f.dtype}")
    f = f.astype(np.int64)
    lo, hi = int(f.min()), int(f.max())
    if lo < 0 or hi >= len(u):
        raise ValueError(f"faces must index uv's {len(u)} rows (0..{len(u) - 1}), got {lo}..{hi}")
    return u, f, size


def _barycentric(tri: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Barycentric weights ``(P, 3)`` of ``points (P, 2)`` in triangles ``tri (P, 3, 2)``.

    Weights are clipped to [0, 1] and renormalised (the points are on or within rounding of
    their triangle); a degenerate triangle interpolates along its longest edge.
    """
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    p = points - tri[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    scale = np.maximum((e1 * e1).sum(1), (e2 * e2).sum(1))
    ok = np.abs(det) > 1e-14 * scale
    safe = np.where(ok, det, 1.0)
    b1 = (p[:, 0] * e2[:, 1] - p[:, 1] * e2[:, 0]) / safe
    b2 = (e1[:, 0] * p[:, 1] - e1[:, 1] * p[:, 0]) / safe
    bary = np.clip(np.stack([1.0 - b1 - b2, b1, b2], axis=1), 0.0, None)
    bary /= np.maximum(bary.sum(axis=1, keepdims=True), np.finfo(float).tiny)
    if not ok.all():
        bary[~ok] = _on_longest_edge(tri[~ok], points[~ok])
    return bary


def _on_longest_edge(tri: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Weights ``(P, 3)`` of ``points`` on the longest edge of degenerate triangles ``tri``."""
    start = np.array([0, 1, 2])
    end = np.array([1, 2, 0])
    lengths = ((tri[:, end] - tri[:, start]) ** 2).sum(-1)  # (P, 3): edges 01, 12, 20
    edge = np.argmax(lengths, axis=1)
    rows = np.arange(len(tri))
    a, b = start[edge], end[edge]
    ab = tri[rows, b] - tri[rows, a]
    length = np.maximum(lengths[rows, edge], np.finfo(float).tiny)
    t = np.clip(((points - tri[rows, a]) * ab).sum(1) / length, 0.0, 1.0)
    bary = np.zeros((len(tri), 3))
    bary[rows, a] = 1.0 - t
    bary[rows, b] += t  # a triangle collapsed to a point puts all the weight on a
    return bary


#: Faces whose boxes are tested at once (:func:`near_grid_faces`): the corners' UVs and the
#: boxes of all 10M faces of a 5M-vertex mesh at once took 1 GB.
_BOX_CHUNK = 1_000_000


def near_grid_faces(
    u: NDArray[np.float64], f: NDArray[np.int64], size: int, *, tolerance: float
) -> NDArray[np.int64]:
    """The faces whose UV box, widened by ``tolerance``, may hold a grid point, increasing.

    Parameters
    ----------
    u : (V, 2) float64 ndarray
        The map of each vertex.
    f : (F, 3) int64 ndarray
        Triangles as indices into ``u``.
    size : int
        Grid size N: the points ``(j, i) / (N - 1)``.
    tolerance : float
        How far outside its box a grid point may lie and still count.

    Returns
    -------
    (K,) int64 ndarray
        Indices into ``f``; every face within ``tolerance`` of a grid point is among them.
    """
    scale = size - 1
    out = []
    for lo in range(0, len(f), _BOX_CHUNK):
        first, last, _ = _grid_boxes(u, f[lo : lo + _BOX_CHUNK], scale, tolerance)
        inside = (first <= last) & (last >= 0) & (first <= scale)
        out.append(lo + np.flatnonzero(inside[:, 0] & inside[:, 1]))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _grid_boxes(
    u: NDArray[np.float64], g: NDArray[np.int64], scale: int, tolerance: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[NDArray[np.float64]]]:
    """The first and last grid index (column j, row i) each face's UV box, widened by
    ``tolerance``, may hold (first > last: none), and the faces' corners' UVs."""
    slack = 1e-9  # grid coordinates are rounded quotients: keep every box that may touch one
    corner = [u[g[:, k]] for k in range(3)]
    a, b, c = corner
    first = np.ceil((np.minimum(np.minimum(a, b), c) - tolerance) * scale - slack)
    last = np.floor((np.maximum(np.maximum(a, b), c) + tolerance) * scale + slack)
    return first, last, corner


#: Face-and-grid-point pairs tested at once (:func:`locate_grid_points`): about 100 MB.
_PAIR_CHUNK = 2_000_000


def locate_grid_points(
    u: NDArray[np.float64], f: NDArray[np.int64], size: int, *, slack: float = 1e-14
) -> NDArray[np.int64]:
    """The UV triangle that holds each grid point, found by scanning each triangle's box.

    Each triangle is tested against the grid points of its bounding box (a raster scan, linear
    in the triangles and the points they cover) by the signs of its three edge functions: a
    point is in a triangle where it lies on the inner side of each edge's line or at most
    ``slack`` outside it.  A point in several (on a shared edge, or within rounding of one)
    takes the lowest-numbered triangle that holds it exactly, else the lowest that holds it
    within ``slack``.  What an AABB tree's closest triangle gives for a point inside the domain,
    without building the tree, and exact where igl's point-triangle distance is not (on a
    sliver it put a point that lies on the triangle's edge 3e-7 away).

    Parameters
    ----------
    u, f, size
        As for :func:`near_grid_faces`: the map of each vertex, the triangles over it, the
        grid size N (grid point ``(j, i) / (N - 1)`` is row ``i * N + j``).
    slack : float, optional
        How far (in UV units) outside a triangle a point may lie and still be in it: rounding
        on an edge.

    Returns
    -------
    (N²,) int64 ndarray
        The triangle's index into ``f`` per grid point, -1 where none holds it (a point off
        the domain, which a closest-point query must answer).

    Examples
    --------
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> locate_grid_points(uv, np.array([[0, 1, 3], [0, 3, 2]]), 3).tolist()
    [0, 0, 0, 1, 0, 0, 1, 1, 0]
    """
    nf = len(f)
    # Half of the triangles in a second thread (numpy's gathers and compares release the
    # GIL), each half into its own array: the lowest triangle is the lowest of the halves'.
    # (igea at N = 1024: 0.26 -> 0.17 s; the same array.)
    half = nf // 2
    with beside(_locate_part, u, f, half, nf, size, slack) as second:
        best = _locate_part(u, f, 0, half, size, slack)
    best = np.minimum(best, second.result())
    found = np.where(best < nf, best, best - nf)
    found[best >= 2 * nf] = -1
    return found


def _locate_part(
    u: NDArray[np.float64],
    f: NDArray[np.int64],
    first: int,
    stop: int,
    size: int,
    slack: float,
) -> NDArray[np.int64]:
    """:func:`locate_grid_points` over the triangles ``first`` to ``stop`` (not included): per
    grid point the lowest of them that holds it exactly, else ``len(f)`` + the lowest that holds
    it within the slack, else ``2 len(f)``."""
    best = np.full(size * size, 2 * len(f), dtype=np.int64)
    chunk = _BOX_CHUNK // 2  # two at once (igea at 5M vertices, N = 256: 7.39 GiB with whole ones)
    for start in range(first, stop, chunk):
        _locate_chunk(u, f, start, min(start + chunk, stop), size, slack, best)
    return best


def _locate_chunk(
    u: NDArray[np.float64],
    f: NDArray[np.int64],
    start: int,
    stop: int,
    size: int,
    slack: float,
    best: NDArray[np.int64],
) -> None:
    """:func:`locate_grid_points` for the faces ``start`` to ``stop`` (a chunk), into ``best``."""
    scale = size - 1
    nf = len(f)
    g = f[start:stop]
    lo, hi, corner = _grid_boxes(u, g, scale, 0.0)
    lo = np.maximum(lo, 0).astype(np.int64)
    width = np.maximum(np.minimum(hi, scale).astype(np.int64) - lo + 1, 0)  # (F, 2): j, i
    count = width[:, 0] * width[:, 1]
    # Edge k runs from corner k to corner k + 1; its function's sign on the triangle's side
    # (orientation) and its length, per triangle.
    edge = [corner[(k + 1) % 3] - corner[k] for k in range(3)]
    det = edge[0][:, 0] * edge[2][:, 1] - edge[0][:, 1] * edge[2][:, 0]
    sign = -np.sign(det)  # edge 0 × (-edge 2): twice the signed area
    reach = [slack * np.hypot(e[:, 0], e[:, 1]) for e in edge]
    ends = np.cumsum(count)
    first = 0
    while first < len(g):
        base = int(ends[first - 1]) if first else 0
        stop = max(int(np.searchsorted(ends, base + _PAIR_CHUNK, side="right")), first + 1)
        faces = np.arange(first, stop)
        faces = faces[(count[faces] > 0) & (sign[faces] != 0)]
        first = stop
        if len(faces) == 0:
            continue
        k = count[faces]
        face = np.repeat(faces, k)
        offset = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
        nj = width[face, 0]
        j = lo[face, 0] + offset % nj
        i = lo[face, 1] + offset // nj
        del offset, nj
        px, py = j / scale, i / scale  # the grid points' own numbers (grid_points)
        s = sign[face]
        exact = np.ones(len(face), dtype=bool)
        near = np.ones(len(face), dtype=bool)
        for e in range(3):
            # The edge function times the orientation: >= 0 on the triangle's side.
            inner = s * (
                edge[e][face, 0] * (py - corner[e][face, 1])
                - edge[e][face, 1] * (px - corner[e][face, 0])
            )
            exact &= inner >= 0
            near &= inner >= -reach[e][face]
        point = i * size + j
        face += start
        np.minimum.at(best, point[exact], face[exact])
        np.minimum.at(best, point[near & ~exact], face[near & ~exact] + nf)


def sampling_matrix(
    uv: NDArray[np.float64],
    faces: NDArray[np.int64],
    n: int,
    *,
    tolerance: float = 1e-10,
) -> Sampling:
    """The barycentric sampling of a parameterised mesh at the N×N grid points.

    Parameters
    ----------
    uv : (V, 2) array_like of float
        The map of each vertex, normally into the unit square ``[0, 1]²``.
    faces : (F, 3) array_like of int
        Triangles as indices into ``uv`` (and into the mesh's vertices), as given.
    n : int
        Grid size N >= 2.
    tolerance : float, optional
        A grid point within this UV distance of a triangle counts as covered (it takes the
        weights of its closest point in that triangle); absorbs rounding on the domain's edge.

    Returns
    -------
    Sampling
        ``matrix`` (N², V) CSR and the ``covered`` (N, N) mask.

    Raises
    ------
    ValueError
        ``uv`` not (V, 2) or not finite, ``faces`` not (F, 3) integers indexing ``uv``,
        ``n`` < 2 (a non-integer ``n`` raises TypeError).

    Notes
    -----
    The grid points are located with an AABB tree over the UV triangles whose bounding box
    (widened by ``tolerance``) holds a grid point (``igl.AABB`` on a copy of ``uv`` padded
    with a zero z; igl crashes on two columns): one squared-distance query per point returns
    the closest triangle and point, ``O(F + N² log N²)``.  A point at distance 0
    lies in that triangle; where triangles overlap (a map that is not injective) one of them is
    used.  For a point ``p`` in triangle ``(a, b, c)`` the row holds
    ``(1 - β - γ, β, γ)`` at columns ``(a, b, c)`` with ``p = a + β (b - a) + γ (c - a)``, so
    ``(S @ x)`` is the piecewise-linear interpolant of any per-vertex ``x`` at the grid points.

    Examples
    --------
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> s = sampling_matrix(uv, np.array([[0, 1, 3], [0, 3, 2]]), 3)
    >>> s.matrix.shape, int(s.covered.sum())
    ((9, 4), 9)
    >>> (s.matrix @ uv)[5].tolist()  # the grid point (i, j) = (1, 2), (u, v) = (1, 0.5)
    [1.0, 0.5]
    """
    u, f, size = _check_inputs(uv, faces, n)
    if not np.isfinite(tolerance) or tolerance < 0:
        raise ValueError(f"tolerance must be a finite number >= 0, got {tolerance}")
    points = grid_points(size)
    # Only triangles whose box (widened by the tolerance) holds a grid point can cover one: a
    # fine mesh has far more triangles than the grid has points (igea at 537k vertices, N =
    # 128: 1.07M triangles, 16k points), and the tree over them all cost a second a sampling.
    near = near_grid_faces(u, f, size, tolerance=tolerance)
    covered = np.zeros(size * size, dtype=bool)
    if len(near) == 0:
        return Sampling(
            matrix=sp.csr_matrix((size * size, len(u))), covered=covered.reshape(size, size)
        )
    used, local = np.unique(f[near], return_inverse=True)
    uv3 = np.column_stack([u[used], np.zeros(len(used))])
    f_near = local.reshape(-1, 3).astype(np.int64)
    p3 = np.column_stack([points, np.zeros(len(points))])
    tree = igl.AABB()
    tree.init(uv3, f_near)
    sq_dist, face_id, closest = tree.squared_distance(uv3, f_near, p3)
    covered = np.asarray(sq_dist) <= tolerance * tolerance
    rows = np.flatnonzero(covered)
    face_id = near[np.asarray(face_id, dtype=np.int64)[rows]]
    corners = f[face_id]  # (P, 3)
    bary = _barycentric(u[corners], np.asarray(closest)[rows, :2])
    keep = bary > 0
    matrix = sp.csr_matrix(
        (bary[keep], (np.repeat(rows, 3).reshape(-1, 3)[keep], corners[keep])),
        shape=(size * size, len(u)),
    )
    return Sampling(matrix=matrix, covered=covered.reshape(size, size))
