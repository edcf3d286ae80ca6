"""Repairing a welded mesh for reading: :func:`drop_irregular`.

Welding close vertices can merge grid samples where the remesh crowded them; the faces around
every vertex no meshwm grid has are dropped, so that each merge reads as a small hole.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components

from meshwm.gim.recover.adjacency import _fans, _Lookup

__all__ = ["drop_irregular"]


def drop_irregular(
    vertices: NDArray, faces: NDArray, *, rings: int = 0
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """The mesh without the faces around vertices no meshwm grid has: for reading a welded mesh.

    Welding close vertices (MeshLab's ``meshing_merge_close_vertices``, whose default merges
    vertices closer than 1/10000 of the bounding-box diagonal) merges grid samples where the
    remesh crowded them, and a merged vertex breaks the walk: triangles around it collapse,
    edges turn non-manifold, two fans meet at one vertex.  Such a vertex is never one a meshwm
    grid writes: it is *irregular* if it has a non-manifold directed edge (two faces with the
    same u -> v), more than one fan of faces (two fans joined at a point), or a closed fan of
    another size than an interior grid sample's (4, 5, 7 or 8 faces; seam vertices of a
    complete grid with other valences are dropped too, which only costs border samples).
    Dropping every face around them turns each merge into a small hole, which the reader
    handles like a crop: the samples there are read as missing.  A cluster of merges can
    also leave wrong faces whose corners all look regular; ``rings`` more rings of faces
    around the irregular vertices are dropped too (1 is enough on the development meshes at
    MeshLab's default threshold, at the cost of 1 to 13 % of the samples).

    Returns
    -------
    vertices, faces : ndarray
        What is left, re-indexed (unused vertices dropped).
    kept : (k,) int64 ndarray
        For each vertex left, its index in the input.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n, m = len(v), len(f)
    lookup = _Lookup(n, f)
    keys = lookup.keys
    fans = _fans(lookup, f)
    u, w, pos, back, first = fans.u, fans.v, fans.back_pos, fans.back, fans.first
    closed, valence = fans.closed, fans.valence
    irregular = np.zeros(n, dtype=bool)
    dup = np.zeros(len(keys), dtype=bool)
    dup[1:] = keys[1:] == keys[:-1]
    irregular[u[dup]] = irregular[w[dup]] = True
    irregular |= closed & ~np.isin(valence, (4, 5, 7, 8))
    # Neighbour classes: in the 4-8 grid an E sample (8 faces, or 7 at a flipped code cell)
    # has at most 4 O and 4 E neighbours (3 at a flipped cell), an O sample (4 faces, or 5)
    # only E neighbours (and its flipped-diagonal O partner).  Two samples merged into one
    # vertex can keep a plausible face count but not these (neighbours whose class is unknown,
    # open or irregular, are not counted).
    is_e, is_o = fans.cls == 0, fans.cls == 1
    n_e = np.bincount(u[first], weights=is_e[w[first]], minlength=n)
    n_o = np.bincount(u[first], weights=is_o[w[first]], minlength=n)
    irregular |= is_e & ((n_o > 4) | (n_e > valence - 4))
    irregular |= is_o & ((n_e > 4) | (n_o > valence - 4))
    # Faces: two E corners and one O, or (a flipped code cell) one E of 7 faces between two O
    # of 5.  A face whose corners are all classed and fit neither is a merge's.
    known = (is_e | is_o)[f].all(axis=1)
    count_e = is_e[f].sum(axis=1)
    flipped = (count_e == 1) & (valence[f] == np.where(is_e[f], 7, 5)).all(axis=1)
    odd = known & (count_e != 2) & ~flipped
    irregular[f[odd].ravel()] = True
    # Fans: the corner of u in the face of u -> w is joined to the corner of u in the face
    # across that edge (the one with w -> u, where u follows w); a vertex whose corners fall
    # into more than one group has more than one fan.
    slot = lookup.order // m  # corner of each edge's first vertex in its face
    corner = slot * m + lookup.face  # corner ids: slot * m + face
    across = ((slot[pos] + 1) % 3) * m + lookup.face[pos]
    a, b = corner[back], across[back]
    graph = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(3 * m, 3 * m)).tocsr()
    _, group = connected_components(graph, directed=False)
    owner = f.T.ravel()  # vertex of corner slot * m + face
    pairs = np.unique(owner.astype(np.int64) * (3 * m) + group)
    irregular |= np.bincount(pairs // (3 * m), minlength=n) > 1
    # A merge also leaves plausible-looking but wrong faces next to the irregular vertices:
    # drop the faces of their neighbours too (``rings`` rings).
    for _ in range(rings):
        irregular[f[irregular[f].any(axis=1)].ravel()] = True
    keep = ~irregular[f].any(axis=1)
    f = f[keep]
    used = np.zeros(n, dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return v[used], remap[f], np.flatnonzero(used)
