"""Verifying a reading, and completing a complete one.

A reading verifies if no face is explained twice (:func:`_explained`), no interior sample shares
its vertex and every face between three interior samples is explained (:func:`_consistent`).  On
a complete grid the samples no vertex holds are the tips of welded folds, which take a perimeter
neighbour's vertex (:func:`_fill_fold_tips`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.recover.adjacency import _Lookup
from meshwm.gim.recover.table import _GridTable


def _explained(
    index: NDArray[np.int64],
    table: _GridTable,
    lookup: _Lookup,
    triangles: NDArray[np.int64] | None = None,
) -> NDArray[np.int64] | None:
    """The faces that are grid triangles of a reading (None if one is explained twice).

    ``triangles``: only these grid triangles (default all of ``table``'s).
    """
    t = index[table.triangles if triangles is None else triangles]
    live = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2]) & (t.min(axis=1) >= 0)
    third, face = lookup(t[live, 0], t[live, 1])
    found = face[(third == t[live, 2]) & (face >= 0)]
    if len(found) and np.bincount(found).max() > 1:
        return None
    return found


def _consistent(
    index: NDArray[np.int64], table: _GridTable, faces: NDArray[np.int64], explained: NDArray
) -> bool:
    """No interior sample shares its vertex (only border samples are welded), and every face
    whose three vertices are interior samples is a grid triangle of the reading."""
    have = index[index >= 0]
    uses = np.bincount(have, minlength=int(faces.max()) + 1)
    inner = index[~table.border]
    inner = inner[inner >= 0]
    if np.any(uses[inner] != 1):
        return False
    interior = np.zeros(len(uses), dtype=bool)
    interior[inner] = True
    boxed = np.asarray(interior[faces].all(axis=1))
    boxed[explained] = False
    return not boxed.any()


def _fill_fold_tips(
    index: NDArray[np.int64], prev: NDArray[np.int64], nxt: NDArray[np.int64]
) -> None:
    """Give the samples that are not in the mesh the vertex of a perimeter neighbour, in place.

    Only for a complete grid (see :func:`~meshwm.gim.recover.recover_grid`): there the missing
    samples are the tips of welded folds (a cut end, or the two corners a path cut joins):
    their triangles closed into fins, which :func:`meshwm.gim.to_mesh.geometry_image_to_mesh`
    drops.  Each takes the vertex of the nearest sample along the perimeter that has one (the
    earlier one in perimeter order on a tie; ``prev``, ``nxt``: the perimeter neighbours,
    :func:`~meshwm.gim.recover.table._perimeter`).  The embedder reads its cover through
    :func:`~meshwm.gim.recover.recover_grid` too, so both sides see the same values there.
    """
    for m in np.flatnonzero(index < 0):
        a, b = m, m
        while index[a] < 0 and index[b] < 0:
            a, b = prev[a], nxt[b]
        index[m] = index[a] if index[a] >= 0 else index[b]
