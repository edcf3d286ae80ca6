"""The entry point of grid recovery: :func:`recover_grid`.

The input is checked, the fast path for faces in the order meshwm wrote them is tried
(:mod:`meshwm.gim.recover.fast`), and otherwise every component is read on its own
(:mod:`meshwm.gim.recover.components`) and the readings of one N merged.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import GridError
from meshwm.gim.recover.adjacency import _Mesh
from meshwm.gim.recover.components import _read_components
from meshwm.gim.recover.fast import _read_in_order
from meshwm.gim.recover.matching import _TRANSFORMS, _code
from meshwm.gim.recover.result import RecoveredGrid
from meshwm.gim.recover.rule_out import rules_out_grid
from meshwm.gim.recover.sizes import _SEARCH_CAP, _candidate_sizes, _in_order_sizes
from meshwm.gim.recover.table import _grid_table
from meshwm.gim.recover.verify import _fill_fold_tips

__all__ = ["recover_grid"]


def recover_grid(vertices: NDArray, faces: NDArray, *, size: int | None = None) -> RecoveredGrid:
    """Find which vertex of a meshwm geometry-image mesh, or of a piece of one, is sample (i, j).

    Parameters
    ----------
    vertices : (k, 3) float64 ndarray
        Vertex positions.  Only used to fill ``gim`` and to spread the seeds over the mesh;
        the grid is read from ``faces``.
    faces : (m, 3) int64 ndarray
        Triangles as written by :func:`meshwm.gim.to_mesh.geometry_image_to_mesh`, then
        possibly re-indexed, re-welded, transformed, or cropped (faces removed, the remaining
        vertices re-indexed; several components are fine).
    size : int, optional
        The grid size N if known (a power of two from 16 to 4096).  By default the N the face
        count fits is tried, then 2N and 4N (up to 2048): a cropped mesh has fewer faces than
        its grid.  The position code tells which is right.

    Returns
    -------
    RecoveredGrid
        ``index`` is -1 and ``gim`` NaN for samples not in the mesh.  On a complete grid (every
        interior sample found, in one component) the tips of welded folds, the only samples a
        complete meshwm mesh lacks, take their perimeter neighbour's vertex, so
        ``coverage`` is 1.0; on a partial one they stay -1.

    Raises
    ------
    GridError
        No component verifies: the mesh was not written by meshwm, or its connectivity was
        changed (remeshed, simplified), or what is left of it is too small to hold a few
        dozen code cells.  Also a vertex no face uses (meshwm writes none, and a crop drops
        them).

    Notes
    -----
    The algorithm is in the docstring of :mod:`meshwm.gim.recover`.  Choices: seed windows of
    11 x 11 code cells (121 bits at most), 8 seeds per component, matched on exact 5 x 5 keys
    and at least 40 agreeing bits connected to the seed (fewer on a grid with fewer code cells,
    N = 16).  A wrong position or orientation agrees on half the bits of a window, so it rarely
    gets that far, and a walk from it meets contradictions.  What is read is always right; what
    may be left unread on a partial grid: pieces too small to hold the code (a few hundred
    faces), pieces across a seam whose windows do not match, and border samples along a cut
    where a fold of the border could not be ruled out.  On the development meshes at N = 128
    and 256, cropped by 10 to 50 %, that is about 0.2 to 0.5 % of the vertices.  A complete
    grid whose faces are still in the order meshwm wrote them is read by a fast path that gives
    the same result (see :mod:`meshwm.gim.recover`).

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.gim.to_mesh import geometry_image_to_mesh
    >>> n = 16
    >>> i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    >>> gim = np.stack([i, j, np.sin(i + j)], axis=-1).astype(float)
    >>> v, f = geometry_image_to_mesh(gim)
    >>> perm = np.random.default_rng(0).permutation(len(v))
    >>> inv = np.argsort(perm)
    >>> grid = recover_grid(v[perm], inv[f])
    >>> grid.n, bool(np.array_equal(grid.gim, gim)), grid.coverage
    (16, True, 1.0)
    """
    v, f = _checked(vertices, faces)
    # Files as meshwm wrote them (and most pipelines pass them on) list the faces in the
    # grid's order: a fast exact reading, verified, else the order-free one.
    for n_try in _in_order_sizes(len(f), size):
        fast = _read_in_order(v, f, n_try, size)
        if fast is not None:
            return fast
    if rules_out_grid(len(v), f):
        raise GridError(
            "no geometry-image grid in the connectivity: in every component most vertices lie "
            "on six triangles, or most faces lack a 4-8 grid face's corners, which a meshwm "
            "grid's never do (the mesh was not written by meshwm, or was remeshed)"
        )
    return _read_order_free(v, f, size)


def _checked(vertices: NDArray, faces: NDArray) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``vertices`` and ``faces`` as float64 and int64 arrays, checked (GridError if not a
    mesh a meshwm grid can be: see :func:`recover_grid`)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise GridError(f"faces must be a non-empty (m, 3) array, got shape {f.shape}")
    if v.ndim != 2 or v.shape[1] != 3:
        raise GridError(f"vertices must be a (k, 3) array, got shape {v.shape}")
    if f.min() < 0 or f.max() >= len(v):
        raise GridError(f"face indices must lie in [0, {len(v) - 1}]")
    used = np.count_nonzero(np.bincount(f.ravel(), minlength=len(v)))
    if used < len(v):
        raise GridError(
            f"{len(v)} vertices is more than the {used} the faces use: a meshwm grid (or a "
            "crop of one) has no free vertex"
        )
    return v, f


def _read_order_free(
    v: NDArray[np.float64], f: NDArray[np.int64], size: int | None
) -> RecoveredGrid:
    """Every component read on its own, then the readings of one N merged."""
    # Sizes from the largest piece: other components (passed through by meshwm) add faces.
    mesh = _Mesh(v, f)
    piece_faces = np.bincount(mesh.label[f[:, 0]], minlength=mesh.n_components).max()
    piece_vertices = np.bincount(mesh.label, minlength=mesh.n_components).max()
    sizes = _candidate_sizes(int(piece_faces), int(piece_vertices), size)
    if not sizes:
        raise GridError(f"{len(v)} vertices is more than an {_SEARCH_CAP} x {_SEARCH_CAP} grid has")
    n0 = sizes[0]
    codes = [_code(n) for n in sizes]
    min_faces = 8 * min(c.min_bits for c in codes)
    comp_faces = np.bincount(mesh.label[f[:, 0]], minlength=mesh.n_components)
    hypotheses = seeded = 0
    readings = []
    for c, reading in _read_components(mesh, codes, min_faces):
        hypotheses += reading.hypotheses
        seeded += reading.seeds
        if reading.index is not None:
            readings.append((reading.n, c, reading.index, reading.faces))
    if not readings:
        also = ", ".join(f"{n} x {n}" for n in sizes[1:])
        raise GridError(
            f"no {n0} x {n0} geometry-image grid found in the connectivity"
            + (f" (nor {also})" if also else "")
            + f" ({hypotheses} hypotheses: {seeded} seed cells x {len(_TRANSFORMS)} "
            f"orientations x {len(sizes)} sizes): the mesh was not written by meshwm, was "
            "remeshed, or too little of it is left"
        )
    n, index, merged = _merge(readings)
    table = _grid_table(n)
    # A complete grid: one component, all of it explained, every interior sample found.  Its
    # missing samples (at most 4N, on the border) are the tips of welded folds.
    complete = (
        len(merged) == 1
        and readings[0][1] == merged[0]
        and readings[0][3] == comp_faces[merged[0]]
        and np.all(index[~table.border] >= 0)
        and np.sum(index < 0) <= 4 * n
    )
    if complete:
        _fill_fold_tips(index, table.prev, table.next)
    grid = index.reshape(n, n)
    found = grid >= 0
    gim = np.full((n, n, 3), np.nan)
    gim[found] = v[grid[found]]
    return RecoveredGrid(n, grid, gim, hypotheses, float(found.mean()), len(merged))


def _merge(
    readings: list[tuple[int, int, NDArray[np.int64], int]],
) -> tuple[int, NDArray[np.int64], list[int]]:
    """(N, flat sample -> vertex map, components merged) of the components' readings
    ``(N, component, index, faces explained)``, largest component first.

    One N: the one that explains the most faces; a sample claimed by two components keeps the
    larger one's vertex and drops the smaller component.
    """
    weight: dict[int, int] = {}
    for n, _, _, explained in readings:
        weight[n] = weight.get(n, 0) + explained
    n = max(sorted(weight), key=lambda k: weight[k])
    index = np.full(n * n, -1, dtype=np.int64)
    merged = []
    for rn, c, part, _ in readings:
        if rn != n:
            continue
        have = part >= 0
        if np.any((index[have] >= 0) & (index[have] != part[have])):
            continue  # a sample claimed by two components: keep the larger one
        index[have] = part[have]
        merged.append(c)
    return n, index, merged
