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
faces, or fewer than :data:`MIN_FIT` of the faces have the corners a 4-8 grid's faces have:
two on 7-9 triangles and one on 3-5, or (a flipped code cell) one and two.  Six is not the
only valence of other meshes: a mesh whose longest edges were split (igea Loop-subdivided
twice, then split to 5M vertices) has 31 % of its vertices on four triangles, 30 % on eight
and only 25 % on six; but 36 % of its faces fit, against 0-19 % on the development meshes and
95-100 % on meshwm grids.  Flips of nearly flat edges lower it (spot's and kitten's grids at
N = 64 and 128: 88-98 % after 100 flips, 77-94 % after 300) long after the grid stops reading
(7 of those 8 grids do not read after 30 flips), so the bound costs no grid that reads.
The search (:func:`meshwm.gim.recover.recover_grid`) would find nothing there, and costs
seconds to say so on a large mesh (the 5M-vertex mesh: 107 s, and the most memory of the
whole extraction).  The connectivity reader asks first
(:func:`meshwm.readers.connectivity.read_grid`), so extracting from a kept mesh does not pay
for the grid search.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

__all__ = ["MAX_SIX", "MIN_FACES", "MIN_FIT", "rules_out_grid"]

#: The largest share of a component's vertices on six faces that may still be a grid (grids:
#: 3 % at most on the development meshes at N = 64; other meshes: 42 % and more).
MAX_SIX = 0.3
#: The smallest share of a component's faces with a 4-8 grid face's corners that may still be
#: a grid (grids: 95 % and more; other meshes: 36 % at most, 51 % when every vertex of a
#: sphere gets a split edge of its own).
MIN_FIT = 0.7
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
        :data:`MAX_SIX` of its vertices on exactly six faces or fewer than :data:`MIN_FIT`
        of its faces with a grid face's corners (and there is such a component).

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
    # A 4-8 grid's face: two corners on 8 faces (7 at a flipped code cell, 9 next to one) and
    # one on 4 (3-5), or, at a flipped code cell, one and two.
    odd = (degree >= 3) & (degree <= 5)
    even = (degree >= 7) & (degree <= 9)
    n_odd, n_even = odd[faces].sum(axis=1), even[faces].sum(axis=1)
    fits = ((n_even == 2) & (n_odd == 1)) | ((n_even == 1) & (n_odd == 2))
    if six.sum() <= MAX_SIX * used.sum() and fits.sum() >= MIN_FIT * len(faces):
        return False  # the whole mesh may be a grid: look no further
    n = int(n_vertices)
    graph = sp.coo_matrix(
        (np.ones(2 * len(faces)), (faces[:, [0, 1]].ravel(), faces[:, [1, 2]].ravel())),
        shape=(n, n),
    )
    n_comp, label = connected_components(graph, directed=False)
    comp_faces = np.bincount(label[faces[:, 0]], minlength=n_comp)
    comp_used = np.bincount(label[used], minlength=n_comp)
    comp_six = np.bincount(label[six], minlength=n_comp)
    comp_fits = np.bincount(label[faces[:, 0]], weights=fits, minlength=n_comp)
    large = comp_faces >= MIN_FACES
    possible = (comp_six <= MAX_SIX * comp_used) & (comp_fits >= MIN_FIT * comp_faces)
    return bool(large.any() and not np.any(possible[large]))
