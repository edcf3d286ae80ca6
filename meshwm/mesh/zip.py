"""Borders zipped: the seams an export split, closed again after the copies drifted apart.

An export that splits vertices along UV seams (glTF always does) leaves each seam as two
borders, one on each side, whose vertices are copies at the same positions.  Cleaning merges
copies that are bit for bit at one position (:mod:`meshwm.mesh.clean`), which restores the
connectivity until something moves the copies apart: noise, or a smoothing of the split mesh
(each side pulled towards its own faces); or it merges too much, where coarse quantisation
made other vertices coincide as well.  :func:`zip_borders` glues the borders alone: border
vertices at one position first, then each border edge left open to the border edge that runs
back along it, when both of its ends lie within a fraction of the longer edge's length of the
other's (:data:`ZIP_TOLERANCE`), each the other's nearest such edge.  The glued vertices take
the mean of their positions.

A real hole is not glued: its border edges run along its rim, never back along one another,
and two rims of one mesh are not within a fraction of an edge of each other along a whole
edge.  Nothing depends on the vertex or face order, the pose or the scale: which edges are glued
is decided by distances relative to the edges' own lengths, and ties between equally near
candidates are not glued.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshwm._validate import check_mesh
from meshwm.mesh.edges import border_half_edges, distinct_rows

__all__ = ["ZIP_TOLERANCE", "Zipped", "zip_borders"]

#: How far apart (as a fraction of the longer edge's length) the ends of two border edges may
#: be for the edges to be glued.  A seam's copies after noise of 0.1 % of the mean distance to
#: the centroid are a median 2-5 % of their shortest edge apart on the development meshes (up
#: to 0.93 on human_neutral's finest faces); no development mesh has two borders this near
#: (at 0.5, stanford_bunny glues one pair of its own).
ZIP_TOLERANCE = 0.3


class Zipped(NamedTuple):
    """Result of :func:`zip_borders`.

    Attributes
    ----------
    vertices : (p, 3) float64 ndarray
        The vertices, each glued group one vertex at its members' mean.
    faces : (m, 3) int64 ndarray
        The faces over them, in the input's order.
    glued : int
        How many vertices were glued to another (0: the mesh as given).
    """

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    glued: int


def _pairs(v: NDArray[np.float64], border: NDArray[np.int64], tolerance: float) -> NDArray:
    """(k, 2) indices into ``border`` of the edge pairs to glue, each pair once."""
    a, b = v[border[:, 0]], v[border[:, 1]]
    length = np.linalg.norm(b - a, axis=1)
    mid = 0.5 * (a + b)
    tree = cKDTree(mid)
    # Each edge's nearest other edge by midpoint (a glued pair's midpoints are within the
    # tolerance times the edge's length of each other); a tie with the runner-up is no one's.
    k = min(3, len(border))
    dist, near = tree.query(mid, k=k)
    dist, near = dist.reshape(len(border), k), near.reshape(len(border), k)
    other = near != np.arange(len(border))[:, None]
    col = np.argmax(other, axis=1)  # the first column that is not the edge itself
    row = np.arange(len(border))
    found = np.where(other[row, col], near[row, col], -1)
    nxt = np.minimum(col + 1, k - 1)
    tie = (nxt > col) & other[row, nxt] & (dist[row, nxt] <= dist[row, col])
    found[tie] = -1
    mutual = np.flatnonzero(found >= 0)
    mutual = mutual[(found[mutual] > mutual) & (found[found[mutual]] == mutual)]
    i, j = mutual, found[mutual]
    p, q = border[i], border[j]
    reach = tolerance * np.maximum(length[i], length[j])
    # Running back along each other (the seam's two sides, each in its face's direction), and
    # not one edge met twice.
    back = np.maximum(
        np.linalg.norm(v[p[:, 0]] - v[q[:, 1]], axis=1),
        np.linalg.norm(v[p[:, 1]] - v[q[:, 0]], axis=1),
    )
    keep = (back < reach) & ~((p[:, 0] == q[:, 1]) & (p[:, 1] == q[:, 0]))
    return np.stack([i[keep], j[keep]], axis=1).astype(np.int64)


def zip_borders(vertices: NDArray, faces: NDArray, *, tolerance: float = ZIP_TOLERANCE) -> Zipped:
    """Glue the border edges that run back along one another (see the module notes).

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    tolerance : float, optional
        How far apart the two edges' ends may be, over the longer edge's length.

    Returns
    -------
    Zipped
        Only border vertices are glued (copies at one position too, where they are on a
        border): other vertices that coincide stay apart, as coarse quantisation makes them,
        and the faces keep their order.

    Examples
    --------
    Two triangles of a square, their shared edge split and one side nudged:

    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0.01], [1, 1, 0.01]])
    >>> z = zip_borders(v, np.array([[0, 1, 2], [4, 5, 3]]))
    >>> z.glued, len(z.vertices), z.faces.tolist()
    (2, 4, [[0, 1, 2], [0, 2, 3]])
    """
    v, f = check_mesh(vertices, faces)
    n = len(v)
    border = border_half_edges(f)
    if len(border) == 0:
        return Zipped(v, f, 0)
    # Copies at one position along the borders first (a seam's exact copies, every corner of
    # an STL soup): one hash of their positions, so that the tree below holds only the borders
    # left open, not every edge of a soup.
    ends = np.unique(border.ravel())
    _, group = distinct_rows(v[ends] + 0.0)  # -0.0 and 0.0 are one position
    first = np.full(int(group.max()) + 1, n, dtype=np.int64)
    np.minimum.at(first, group, ends)
    link = np.arange(n)
    link[ends] = first[group]
    rows, cols = [ends], [link[ends]]
    open_border = border_half_edges(link[f])
    if len(open_border) > 1:
        pairs = _pairs(v, open_border, float(tolerance))
        p, q = open_border[pairs[:, 0]], open_border[pairs[:, 1]]
        rows += [p[:, 0], p[:, 1]]
        cols += [q[:, 1], q[:, 0]]
    head, tail = np.concatenate(rows), np.concatenate(cols)
    graph = sp.coo_matrix((np.ones(len(head)), (head, tail)), shape=(n, n))
    count_groups, label = connected_components(graph, directed=False)
    if count_groups == n:
        return Zipped(v, f, 0)
    # Each group's position: its members' mean, summed in the order of their positions (not
    # their indices), so that a reordered mesh gives the same bits.
    order = np.lexsort((*v.T[::-1], label))
    count = np.bincount(label)
    total = np.zeros((len(count), 3))
    for c in range(3):
        np.add.at(total[:, c], label[order], v[order, c])
    merged = total / count[:, None]
    # Number the groups by their first vertex in the input's order.
    seen = np.full(len(count), n, dtype=np.int64)
    np.minimum.at(seen, label, np.arange(n))
    number = np.empty(len(count), dtype=np.int64)
    number[np.argsort(seen, kind="stable")] = np.arange(len(count))
    return Zipped(merged[np.argsort(seen, kind="stable")], number[label][f], n - len(count))
