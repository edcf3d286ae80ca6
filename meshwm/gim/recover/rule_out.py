"""A cheap test that a mesh holds no meshwm grid, before the full search.

A meshwm grid is a 4-8 mesh (:func:`meshwm.gim.code.grid_faces`): its interior samples lie on
4 or 8 triangles, one more or one fewer where a code cell's diagonal is flipped (each sample
is a corner of one code cell at most), so on 3, 4, 5, 7, 8 or 9, never 6.  Only the border
ring and the welded seams, O(N) of the N² samples, can lie on six.  Most other triangle meshes
have most of their vertices on six triangles (a regular triangulation's valence): the
development meshes 42-96 %, igea Loop-subdivided once 91 %; meshwm grids 0.1-3 % (spot,
kitten, plane_holes at N = 64 and 128).  A crop, a weld, a few flips or a seam split change
the count only along what they touch.

:func:`rules_out_grid` says a mesh holds no grid when in every connected component of at
least :data:`MIN_FACES` faces more than :data:`MAX_SIX` of the vertices lie on exactly six
faces: the search (:func:`meshwm.gim.recover.recover_grid`) would find nothing there, and
costs seconds to say so on a large mesh.  The connectivity reader asks first
(:func:`meshwm.readers.connectivity.read_grid`), so extracting from a kept mesh does not pay
for the grid search.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

__all__ = ["MAX_SIX", "MIN_FACES", "rules_out_grid"]

#: The largest share of a component's vertices on six faces that may still be a grid (grids:
#: 3 % at most on the development meshes at N = 64; other meshes: 42 % and more).
MAX_SIX = 0.3
#: Components with fewer faces are not looked at (they hold no code a reader could match).
MIN_FACES = 64


def rules_out_grid(n_vertices: int, faces: NDArray[np.int64]) -> bool:
    """True when no component of the connectivity can be (part of) a meshwm grid.

    Parameters
    ----------
    n_vertices : int
    faces : (m, 3) int64 ndarray
        The connectivity as given.

    Returns
    -------
    bool
        True if every component with at least :data:`MIN_FACES` faces has more than
        :data:`MAX_SIX` of its vertices on exactly six faces (and there is such a component).

    Examples
    --------
    >>> from meshwm.gim.code import grid_faces
    >>> rules_out_grid(64 * 64, grid_faces(64))
    False
    """
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) < MIN_FACES:
        return False
    degree = np.bincount(faces.ravel(), minlength=n_vertices)
    used = degree > 0
    six = degree == 6
    if six.sum() <= MAX_SIX * used.sum():  # the whole mesh may be a grid: look no further
        return False
    n = int(n_vertices)
    graph = sp.coo_matrix(
        (np.ones(2 * len(faces)), (faces[:, [0, 1]].ravel(), faces[:, [1, 2]].ravel())),
        shape=(n, n),
    )
    n_comp, label = connected_components(graph, directed=False)
    comp_faces = np.bincount(label[faces[:, 0]], minlength=n_comp)
    comp_used = np.bincount(label[used], minlength=n_comp)
    comp_six = np.bincount(label[six], minlength=n_comp)
    large = comp_faces >= MIN_FACES
    return bool(large.any() and np.all(comp_six[large] > MAX_SIX * comp_used[large]))
