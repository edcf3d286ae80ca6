"""Back from a geometry image to a triangle mesh: the grid triangulation, its seams welded.

Every grid sample becomes a vertex and every cell two triangles
(:func:`meshwm.gim.code.grid_faces`, which carries the position code).  With the weld map of
:func:`meshwm.gim.remesh.mesh_to_geometry_image` the two sides of each cut become one vertex,
which closes the seams; triangles that collapse there, and the pairs of opposite triangles
(fins) left at the ends of a cut, are dropped.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.code import grid_faces

__all__ = ["geometry_image_to_mesh"]


def _welded_grid_faces(n: int, weld: NDArray[np.int64]) -> NDArray[np.int64]:
    """:func:`_weld_faces` of the whole grid (``grid_faces(n)``), the same array, from the
    triangles around the welded samples and their roots only.

    A triangle can collapse, or be a fin's, only if it has a welded sample or a root among
    its corners; every other row is the grid's own.  So those triangles are found from the
    samples' cells, the rows between them copied as they are.  (At N = 1024 a few thousand
    triangles of two million: 0.12 -> 0.03 s, the row masks and the gathers over the whole
    grid no longer made.)
    """
    faces = grid_faces(n)
    root = np.asarray(weld, dtype=np.int64).reshape(-1)
    moved = np.flatnonzero(root != np.arange(n * n))
    if len(moved) == 0:
        return faces.copy()
    special = np.union1d(moved, root[moved])
    i, j = np.divmod(special, n)
    ci = i[:, None] + np.array([-1, -1, 0, 0])
    cj = j[:, None] + np.array([-1, 0, -1, 0])
    inside = (ci >= 0) & (ci <= n - 2) & (cj >= 0) & (cj <= n - 2)
    cells = np.unique((ci * (n - 1) + cj)[inside])
    rows = np.stack([2 * cells, 2 * cells + 1], axis=1).reshape(-1)  # ascending
    welded = root[faces[rows]]
    bad = (welded[:, 0] == welded[:, 1]) | (welded[:, 1] == welded[:, 2])
    bad |= welded[:, 0] == welded[:, 2]
    at_root = np.zeros(n * n, dtype=bool)
    at_root[root[moved]] = True
    twin = _twins(welded, np.flatnonzero(~bad & at_root[welded].any(axis=1)))
    drop = rows[bad | twin]
    out = np.empty((len(faces) - len(drop), 3), dtype=np.int64)
    start = at = 0
    for stop in [*drop.tolist(), len(faces)]:  # the runs of rows between dropped ones
        out[at : at + stop - start] = faces[start:stop]
        at += stop - start
        start = stop + 1
    kept = ~(bad | twin)
    out[rows[kept] - np.searchsorted(drop, rows[kept])] = welded[kept]
    return out


def _weld_faces(faces: NDArray[np.int64], weld: NDArray[np.int64]) -> NDArray[np.int64]:
    """Grid triangles on the welded samples, collapsed triangles and fins left out."""
    root = np.asarray(weld, dtype=np.int64).reshape(-1)
    faces = root[faces]
    bad = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    faces = faces[~bad]
    # A welded cut end leaves a pair of opposite triangles on the same three vertices (a
    # fin): drop both.  The grid's own triangles are distinct, so one of a pair had a sample
    # welded to another: both use that sample's root, and only triangles at a root are
    # compared (a million triangles at N = 1024, a few thousand along the seams).
    at_root = np.zeros(len(root), dtype=bool)
    at_root[root[root != np.arange(len(root))]] = True
    return faces[~_twins(faces, np.flatnonzero(at_root[faces].any(axis=1)))]


def _twins(faces: NDArray[np.int64], near: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Per row of ``faces``: whether it is one of the rows ``near`` whose three vertices
    another of them has too (a fin's two triangles)."""
    key = np.sort(faces[near], axis=1)
    order = np.lexsort(key.T[::-1])
    ks = key[order]
    same = np.all(ks[1:] == ks[:-1], axis=1)
    twin = np.zeros(len(faces), dtype=bool)
    twin[near[order[1:][same]]] = True
    twin[near[order[:-1][same]]] = True
    return twin


def geometry_image_to_mesh(
    gim: NDArray[np.float64],
    weld: NDArray[np.int64] | None = None,
    *,
    other_vertices: NDArray | None = None,
    other_faces: NDArray | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Turn a geometry image back into a triangle mesh.

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The geometry image.
    weld : (N, N) int64 ndarray, optional
        Weld map from :func:`meshwm.gim.remesh.mesh_to_geometry_image`; welded samples become
        one vertex, which closes the cut seams.  Without it the grid is returned open.
    other_vertices, other_faces : ndarray, optional
        Extra components appended unchanged after the grid.

    Returns
    -------
    vertices : (k, 3) float64 ndarray
        Grid vertices in row-major order (welded and unused ones left out), then the others.
    faces : (l, 3) int64 ndarray
        Two triangles per cell, oriented like the input; triangles that collapse when a seam
        is welded (at the ends of a cut) are left out.
    """
    gim = np.asarray(gim, dtype=np.float64)
    if gim.ndim != 3 or gim.shape[0] != gim.shape[1] or gim.shape[2] != 3:
        raise ValueError(f"gim must have shape (N, N, 3), got {gim.shape}")
    n = gim.shape[0]
    flat = gim.reshape(-1, 3)
    faces = grid_faces(n) if weld is None else _welded_grid_faces(n, weld)
    used = np.zeros(n * n, dtype=bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    vertices = flat[used]
    faces = remap[faces]
    if other_faces is not None and len(other_faces):
        ov = np.asarray(other_vertices, dtype=np.float64)
        faces = np.vstack([faces, np.asarray(other_faces, dtype=np.int64) + len(vertices)])
        vertices = np.vstack([vertices, ov])
    return vertices, faces.astype(np.int64, copy=False)
