"""Sampling the map onto the N×N grid: the geometry image and the weld map of its seams.

Each grid point is located in the mesh's own UV triangles (a scan of each triangle's box) and
interpolated barycentrically; a point the UV domain misses takes the closest point of the
domain (``igl.AABB`` over UVs padded with a zero z), so the image has no holes and no NaN.
Boundary samples are evaluated on the 3-D boundary chains directly
(:mod:`meshwm.gim.boundary`), so both sides of a cut get the same point; the weld map records
which samples are one.
"""

from __future__ import annotations

import igl
import numpy as np
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm.gim.boundary import Chains, unit_to_uv
from meshwm.gim.sampling import locate_grid_points, near_grid_faces

__all__ = ["sample_geometry_image"]


def _perimeter_grid_index(n: int) -> NDArray[np.int64]:
    """(i, j) of the grid sample at each integer perimeter position 0 .. 4(N-1) - 1."""
    side = n - 1
    t = np.arange(4 * side)
    uv = unit_to_uv(t.astype(float), n)
    j = np.rint(uv[:, 0] * side).astype(np.int64)
    i = np.rint(uv[:, 1] * side).astype(np.int64)
    return np.stack([i, j], axis=1)


#: Grid points within this UV distance of a triangle are looked up among the triangles near
#: the grid points only (:func:`meshwm.gim.sampling.near_grid_faces`).
_NEAR = 1e-9


def _closest_faces(
    uv: NDArray[np.float64], faces: NDArray[np.int64], points: NDArray[np.float64], n: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """For each (x, y, 0) grid point the closest UV triangle and the closest point on it.

    A point inside the domain is its own closest point, in the triangle that holds it
    (:func:`meshwm.gim.sampling.locate_grid_points`, a scan of each triangle's box).  The
    points no triangle holds (a map that misses part of the square) ask an AABB tree: over the
    triangles whose box, widened by :data:`_NEAR`, holds a grid point (one left out is farther
    than ``_NEAR`` from every grid point), and a point farther than that over them all.
    """
    face_id = locate_grid_points(uv, faces, n)
    closest = np.array(points, dtype=np.float64)
    rest = np.flatnonzero(face_id < 0)
    if len(rest) == 0:
        return face_id, closest
    uv3 = np.column_stack([uv, np.zeros(len(uv))])
    near = near_grid_faces(uv, faces, n, tolerance=_NEAR)
    if len(near) == 0:  # no triangle near any grid point: every point asks the whole tree
        near = np.arange(len(faces))
    tree = igl.AABB()
    tree.init(uv3, faces[near])
    sq_dist, near_id, near_closest = tree.squared_distance(uv3, faces[near], points[rest])
    face_id[rest] = near[np.asarray(near_id, dtype=np.int64)]
    closest[rest] = near_closest
    far = rest[np.asarray(sq_dist) > _NEAR * _NEAR]
    if len(far):
        tree = igl.AABB()
        tree.init(uv3, faces)
        _, far_id, far_closest = tree.squared_distance(uv3, faces, points[far])
        face_id[far], closest[far] = far_id, far_closest
    return face_id, closest


def _sample_interior(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    n: int,
) -> NDArray[np.float64]:
    """Sample the surface at the N×N grid points of the unit square (barycentric in UV)."""
    g = np.arange(n) / (n - 1)
    uu, vv = np.meshgrid(g, g)  # uu[i, j] = j / (N - 1), vv[i, j] = i / (N - 1)
    points = np.stack([uu.ravel(), vv.ravel(), np.zeros(n * n)], axis=1)
    face_id, closest = _closest_faces(uv, faces, points, n)
    # Each point's weights and position depend on it alone: half of them in a second thread
    # (igea at N = 1024: 0.27 -> 0.17 s; the same numbers, row by row).
    xyz = np.empty((n * n, 3))
    half = np.s_[: n * n // 2], np.s_[n * n // 2 :]
    with beside(_interpolate, vertices, faces, uv, face_id, closest, half[1], xyz) as second:
        _interpolate(vertices, faces, uv, face_id, closest, half[0], xyz)
    second.result()  # its error, if it raised one
    return xyz.reshape(n, n, 3)


def _interpolate(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    face_id: NDArray[np.int64],
    closest: NDArray[np.float64],
    part: slice,
    out: NDArray[np.float64],
) -> None:
    """The surface at the UV points ``closest[part]`` of triangles ``face_id[part]``
    (barycentric), into ``out[part]``."""
    face_id = face_id[part]
    tri = uv[faces[face_id]]  # (P, 3, 2)
    p = closest[part, :2]
    v0 = tri[:, 1] - tri[:, 0]
    v1 = tri[:, 2] - tri[:, 0]
    v2 = p - tri[:, 0]
    d00 = (v0 * v0).sum(1)
    d01 = (v0 * v1).sum(1)
    d11 = (v1 * v1).sum(1)
    d20 = (v2 * v0).sum(1)
    d21 = (v2 * v1).sum(1)
    den = d00 * d11 - d01 * d01
    den = np.where(den != 0, den, 1.0)
    b1 = (d11 * d20 - d01 * d21) / den
    b2 = (d00 * d21 - d01 * d20) / den
    bary = np.clip(np.stack([1.0 - b1 - b2, b1, b2], axis=1), 0.0, None)
    bary /= bary.sum(axis=1, keepdims=True)
    out[part] = np.einsum("pk,pkd->pd", bary, vertices[faces[face_id]])


def _sample_boundary(gim: NDArray[np.float64], chains: Chains, n: int) -> NDArray[np.int64]:
    """Overwrite the perimeter samples of ``gim`` from the 3-D chains; return the weld map."""
    perim = _perimeter_grid_index(n)
    key_to_flat: dict[tuple, int] = {}
    weld = np.arange(n * n, dtype=np.int64).reshape(n, n)
    for r, c in enumerate(chains.run_chain):
        steps = int(chains.chain_steps[c])
        pts = chains.chain_points[c]
        keys = chains.chain_keys[c]
        for t in range(steps):
            pos = int(chains.run_unit[r]) + t
            k = steps - t if chains.run_reversed[r] else t
            i, j = perim[pos]
            gim[i, j] = pts[k]
            if chains.chain_multiplicity[c] == 2 or keys[k][0] == "v":
                flat = key_to_flat.setdefault(keys[k], int(i * n + j))
                weld[i, j] = flat
    # Nodes reached through a border chain only still weld with their cut-side twins (above);
    # make the weld map idempotent (every sample points at a root that points at itself).
    flat_weld = weld.ravel()
    flat_weld = flat_weld[flat_weld]
    return flat_weld.reshape(n, n)


def sample_geometry_image(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    uv: NDArray[np.float64],
    chains: Chains,
    n: int,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Sample the mapped surface at the N×N grid points.

    Parameters
    ----------
    vertices : (k, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        The cut mesh with its corners split (:class:`meshwm.gim.boundary.Disk`).
    uv : (k, 2) float64 ndarray
        The map of each vertex into the unit square.
    chains : Chains
        The boundary chains the perimeter samples are taken from.
    n : int
        Grid size N.

    Returns
    -------
    gim : (N, N, 3) float64 ndarray
        ``gim[i, j]`` is the surface point at ``(u, v) = (j, i) / (N - 1)``.
    weld : (N, N) int64 ndarray
        Flat index of the sample each sample is welded to (itself if none); idempotent.
    """
    gim = _sample_interior(vertices, faces, uv, n)
    # Boundary samples straight from the 3-D chains: both sides of a cut get the same point.
    weld = _sample_boundary(gim, chains, n)
    return gim, weld
