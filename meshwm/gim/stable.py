"""A cut to a topological disk that the mark, noise, similarities and element order do not move.

The cut is made from the mesh's connectivity alone, in a *canonical vertex labelling*; geometry
enters through one choice only, the labelling's starting half-edge, and that is read off a
smoothed copy of the mesh (:func:`smoothed_copy`), where the mark and noise have been averaged
away.

Why this labelling
------------------
``igl.cut_to_disk`` depends on the order of the vertices and faces.  Sorting them by a geometric
key (distance to the centroid, as :mod:`meshwm.gim.cut` does) makes the cut independent of the
file's order but not of noise: every near-tie in the key can swap two labels, and a swap
anywhere changes the cut.  Here the order is a breadth-first traversal that visits each vertex's
neighbours in their rotation order around it (counter-clockwise through the faces, starting at
the neighbour it was reached from), the classical canonical form of an embedded graph: given
the starting half-edge it depends on the connectivity only, so a permutation of the vertices or
faces, a similarity, the mark or noise can change the labelling (and so the cut) only by moving
the starting half-edge.  That half-edge is chosen on the smoothed copy by similarity-invariant
quantities: the vertex farthest from the area centroid, and its neighbour along its longest
smoothed edge.  A closed genus-0 mesh, which ``igl.cut_to_disk`` leaves uncut, is cut along
the breadth-first tree path from that vertex to the last vertex labelled (one of the fewest-hops
farthest).  (A geodesic path on the smoothed copy between geometric ends survived 10 flips on
cow where this one does not, but a smoothing attack then moved it; the flips are lost to the
map's own sensitivity anyway, see docs/keep.md.)  Where the farthest vertex is a near-tie
between two tips, the mark alone can swap them (spot: 8e-6 of the radius apart), so a reader
also tries the runner-up tips (``rank``).  Surfaces with small holes reach this case too, their
holes filled (:mod:`meshwm.gim.holes`, :mod:`meshwm.gim.surface`).

Measured (2026-12-01, ``tests/gim/test_stable.py`` and a probe over the dev meshes spot, cow,
fandisk, camelhead (closed genus 0), kitten (genus 1), fertility (genus 4), bunny, plane_holes
(27 holes) and human_neutral's largest component): random similarities (scale 0.01-100,
translation ±100) and vertex/face permutations give the same cut, and UVs equal to 1e-13; noise
of 0.1 % and 0.3 % of the mean distance to the centroid and 16- to 8-bit quantisation give the
same cut on all of them (UVs then move by 0: the map depends on the connectivity only).  The
start's margins on the smoothed copy: the farthest vertex beats the next by 8e-6 (spot) to 1e-3
(fandisk) of the radius, the longest edge the next by 5-40 %; 50 smoothing steps shrink the
noise far below that.  What moves the cut is a change of connectivity: edge flips relabel
everything the traversal reaches after them (10 flips of nearly flat edges: spot's cut and map
change, 28 samples median at N = 256; kitten's cut loses an edge; fandisk's cut holds and its
map moves 0.03 samples median, 1.4 at most).

The input must be a connected, consistently oriented, edge-manifold triangle mesh (the output of
:func:`meshwm.mesh.clean.clean_mesh`); a vertex whose faces form several fans is traversed
through the fan it is reached by.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Iterator
from concurrent.futures import Future
from contextlib import contextmanager
from typing import NamedTuple

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import connected_components, dijkstra, reverse_cuthill_mckee

from meshwm._concurrent import beside
from meshwm._digest import LastResult, arrays_key
from meshwm.errors import MeshError
from meshwm.gim.cut import CutMesh, area_centroid, cut_open, path_edges
from meshwm.mesh.clean import euler_characteristic, uniform_smoothing_operator, unique_edges
from meshwm.mesh.edges import canonical_faces

__all__ = [
    "EDGE_MARGIN",
    "RADIAL_MARGIN",
    "TIPS",
    "StableCut",
    "canonical_labelling",
    "cut_start",
    "nudge_start",
    "smoothed_copy",
    "smoothed_near",
    "stable_cut",
]

#: The tips (local maxima of the distance to the centroid) a start may be taken at.
TIPS = 4
#: Relative margin under which a tip's two longest smoothed edges are a near-tie (the genus-8
#: plate's corner: 8e-4, which the mark crosses; the dev meshes: 5-40 %).
EDGE_MARGIN = 0.03
#: Relative gap in the distance to the centroid under which the next farthest vertex (a
#: neighbour of the farthest, not a tip of its own) is a near-tie for the source: igea's top is
#: flat, its three farthest vertices 6e-6 and 6e-5 apart, and 10 Laplacian steps swap them.
RADIAL_MARGIN = 1e-4


class StableCut(NamedTuple):
    """A cut to a disk and the mesh cut open along it.

    Attributes
    ----------
    mesh : CutMesh
        The input cut open (``igl.cut_mesh``): its vertices are the input's positions (not the
        smoothed ones), its faces are the input's faces in the input's order.
    edges : (e, 2) int64 ndarray
        The cut's edges as pairs of input vertex indices, each pair sorted, rows sorted.
    order : (n,) int64 ndarray
        The canonical labelling: ``order[k]`` is the input vertex labelled ``k``.
    near_ties : tuple of int
        The ranks (:func:`stable_cut`) whose start is a near-tie of a start of rank < TIPS:
        ``TIPS + t`` where tip ``t``'s two longest smoothed edges are within
        :data:`EDGE_MARGIN` of each other, ``2 * TIPS + j`` where the ``j + 2``-th farthest
        vertex is within :data:`RADIAL_MARGIN` of the farthest; a reader tries them too.
    """

    mesh: CutMesh
    edges: NDArray[np.int64]
    order: NDArray[np.int64]
    near_ties: tuple[int, ...] = ()


def smoothed_copy(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, steps: int = 50, lam: float = 0.5
) -> NDArray[np.float64]:
    """Uniform Laplacian smoothing: ``steps`` times ``v += lam * (M v - v)``.

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
    steps : int, default 50
        Number of smoothing steps (>= 0).
    lam : float, default 0.5
        Step size in (0, 1].

    Returns
    -------
    (n, 3) float64 ndarray
        The smoothed positions (boundaries are smoothed as polylines of their own, see
        :func:`meshwm.mesh.clean.uniform_smoothing_operator`).  Every step is an affine
        combination of neighbours, so a similarity of the input moves the copy by the same
        similarity.

    Examples
    --------
    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> bool(smoothed_copy(v, f, steps=60).std(axis=0).max() < 1e-12)
    True
    """
    if int(steps) != steps or steps < 0:
        raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
    if not 0.0 < lam <= 1.0:
        raise ValueError(f"lam must be in (0, 1], got {lam!r}")
    v = np.array(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    return _repeat(_step(len(v), faces, lam), v, int(steps))


def _step(
    n: int, faces: NDArray[np.int64], lam: float
) -> tuple[NDArray[np.int64] | None, sp.csr_matrix]:
    """The smoothing step of this connectivity, localised (:func:`_localised`), kept in
    :data:`_STEP_MEMO`."""
    key = (*arrays_key(faces), n, float(lam))
    local: tuple[NDArray[np.int64] | None, sp.csr_matrix] | None = _STEP_MEMO.get(key)
    if local is None:
        local = _localised(_smoothing_step(n, faces, lam))
        if n <= _STEP_MEMO_ROWS:
            _STEP_MEMO.put(key, local)
    return local


#: The last mesh's smoothing step (renumbered, :func:`_localised`): the embedder smooths one
#: connectivity four or five times (the input, the start's checks, the read-back).  Kept only
#: up to this many vertices (at 5M the step alone is 0.4 GB; kept, it put the embedding's
#: peak over 8 GB while the transfer factorised the mesh's own system, which it no longer
#: does: 6.5 GiB without it; building it again cost 7.6 s a check at 5M).
_STEP_MEMO = LastResult()
_STEP_MEMO_ROWS = 6_000_000


#: Above this many rows, :func:`_repeat` renumbers the rows for locality first.
_LOCAL_ROWS = 50_000


def _localised(matrix: sp.csr_matrix) -> tuple[NDArray[np.int64] | None, sp.csr_matrix]:
    """``matrix`` renumbered for locality (see :func:`_repeat`), and the new order (None: as
    it was, at most :data:`_LOCAL_ROWS` rows)."""
    n = matrix.shape[0]
    if n <= _LOCAL_ROWS:
        return None, matrix
    order = reverse_cuthill_mckee(matrix, symmetric_mode=True).astype(np.int64)
    rank = np.empty_like(order)
    rank[order] = np.arange(n)
    counts = np.diff(matrix.indptr)[order]
    indptr = np.concatenate([[0], np.cumsum(counts)])
    take = np.repeat(matrix.indptr[order] - indptr[:-1], counts) + np.arange(indptr[-1])
    local = sp.csr_matrix((matrix.data[take], rank[matrix.indices[take]], indptr), shape=(n, n))
    return order, local


def _repeat(
    localised: tuple[NDArray[np.int64] | None, sp.csr_matrix], x: NDArray[np.float64], times: int
) -> NDArray[np.float64]:
    """A matrix (as :func:`_localised` gives it) applied ``times`` times to ``x``: the same bits
    as the plain loop over the matrix as it was.

    A large mesh's vertex order scatters each row's neighbours over memory (a Loop-subdivided
    mesh appends its new vertices); renumbered by reverse Cuthill-McKee, with each row's terms
    kept in their order (so every sum adds the same terms in the same order), the products
    read memory in order: 50 steps at 537k vertices 1.17 s → 0.58 s.
    """
    order, matrix = localised
    y = x if order is None else x[order]
    for _ in range(times):
        y = matrix @ y
    return _in_given_order(order, y)


def _in_given_order(order: NDArray[np.int64] | None, y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rows of ``y`` in :func:`_localised`'s ``order`` put back in the matrix's own order."""
    if order is None:
        return y
    out = np.empty_like(y)
    out[order] = y
    return out


def _repeat_near(
    localised: tuple[NDArray[np.int64] | None, sp.csr_matrix], x: NDArray[np.float64], times: int
) -> NDArray[np.float64]:
    """:func:`_repeat` of the localised matrix's *transpose* (``matrix.T.tocsr()``), the same
    bits, in time proportional to the rows ``x`` reaches rather than to the matrix.

    Each row of a CSR product is a sum from ``+0.0`` of its terms in their stored order (the
    transpose's row ``i``: ``M[j, i] y[j]`` by ascending ``j``), and a partial sum from
    ``+0.0`` is never ``-0.0``, so a zero term (``y[j] = ±0``) leaves it as it is: only the
    rows ``j`` where ``y`` is nonzero need be read, and a row no such ``j`` reaches is
    ``+0.0``, as in the whole product.  So each step multiplies the rows of ``M`` at the
    nonzero rows of ``y``, transposed (which keeps ascending ``j`` in every row).
    (:func:`nudge_start`'s ``Pᵀg`` starts on two vertices: at 2.1M vertices 50 whole products
    took 3.2 s for a bump on 7,189 vertices.)
    """
    order, matrix = localised
    n = matrix.shape[0]
    y = np.asarray(x if order is None else x[order], dtype=np.float64)
    rows = np.flatnonzero(np.any(y != 0, axis=1))
    values = y[rows]
    done = 0
    while done < times and 8 * len(rows) <= n:
        block = matrix[rows]
        columns, local = np.unique(block.indices, return_inverse=True)
        block = sp.csr_matrix(
            (block.data, local.ravel(), block.indptr), shape=(len(rows), len(columns))
        )
        values = block.T.tocsr() @ values
        rows = columns
        done += 1
    out = np.zeros_like(y)
    out[rows] = values
    if done < times:  # reached an eighth of the mesh: the whole product from there
        transposed = matrix.T.tocsr()
        for _ in range(times - done):
            out = transposed @ out
    return _in_given_order(order, out)


def _smoothing_step(n: int, faces: NDArray[np.int64], lam: float) -> sp.csr_matrix:
    """One step as one matrix: (1 - lam) v + lam M v where a vertex has neighbours, else v."""
    operator, has_neighbours = uniform_smoothing_operator(n, faces)
    return sp.csr_matrix(sp.diags(np.where(has_neighbours, 1.0 - lam, 1.0)) + lam * operator)


def nudge_start(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    source: int,
    *,
    margin: float,
    steps: int = 50,
    lam: float = 0.5,
) -> NDArray[np.float64] | None:
    """The least-norm displacement that makes ``source`` the farthest vertex of the smoothed
    copy again, ahead of the current farthest by ``margin`` of its distance (to first order).

    The smoothed copy is linear in the vertices, ``s = P v`` (:func:`smoothed_copy`), so the
    gap ``g·s`` between the two distances to the centroid (``g``: the unit directions, ``+`` at
    ``source`` and ``-`` at the rival) moves by ``g·P δ``, and the least ``δ`` moving it by
    ``Δ`` is ``Δ Pᵀg / |Pᵀg|²``: a smooth bump around the two vertices.  The embedder uses it
    where its mark tipped a near-tie of the cut's start (:func:`cut_start`), so that the marked
    mesh keeps the input's cut and map.

    Returns
    -------
    (n, 3) float64 ndarray or None
        None where ``source`` is already the farthest by ``margin``.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    smooth, _, _ = _smoothed_sources(vertices, faces, steps=steps, lam=lam)
    offset = smooth - area_centroid(smooth, faces)
    radial = np.linalg.norm(offset, axis=1)
    others = radial.copy()
    others[source] = -np.inf
    rival = int(np.argmax(others))
    deficit = radial[rival] - (1.0 - margin) * radial[source]
    if deficit <= 0 or radial[source] <= 0 or radial[rival] <= 0:
        return None
    g = np.zeros_like(vertices)
    g[source] = offset[source] / radial[source]
    g[rival] = -offset[rival] / radial[rival]
    # Pᵀ is the kept step's transpose, in the same local order as the step itself; g lives on
    # two vertices, and each step spreads it one ring only (_repeat_near).
    order, local = _step(len(vertices), faces, lam)
    g = _repeat_near((order, local), g, int(steps))
    norm2 = float((g * g).sum())
    return None if norm2 <= 0 else (deficit / norm2) * g


class _Rotation(NamedTuple):
    """Half-edges (a, b) sorted by key ``a * n + b``, with their twin, and their fans: the
    half-edges around a vertex in rotation order (successor: (a, c) after (a, b) for face abc),
    one fan after the other, each from its first half-edge (a closed fan: its smallest key)."""

    target: NDArray[np.int64]
    twin: NDArray[np.int64]
    keys: NDArray[np.int64]
    fan: NDArray[np.int64]  # the fan of each half-edge
    position: NDArray[np.int64]  # each half-edge's place in its fan
    members: NDArray[np.int64]  # the half-edges fan by fan, each fan in rotation order
    start: NDArray[np.int64]  # where each fan begins in ``members`` (one more at the end)


def _rotation(n: int, faces: NDArray[np.int64]) -> _Rotation:
    """The rotation system: around vertex a, half-edge (a, b) is followed by (a, c) for face abc."""
    a = faces.ravel()
    b = faces[:, [1, 2, 0]].ravel()
    c = faces[:, [2, 0, 1]].ravel()
    m3 = len(a)
    # Every corner gives (a, b) and (a, c); one sort numbers the distinct half-edges.
    # Each temporary is dropped once used (at 5M vertices, 30M corners, each of these is
    # 0.24-0.48 GB, and all of them held to the end made the embedding's peak).
    both = np.concatenate([a * n + b, a * n + c])
    del b, c
    order = np.argsort(both, kind="stable")
    ranked = both[order]
    del both
    new = np.ones(len(ranked), dtype=bool)
    new[1:] = ranked[1:] != ranked[:-1]
    keys = ranked[new]
    del ranked
    index = np.empty(len(order), dtype=np.int64)
    index[order] = np.cumsum(new) - 1
    del order, new
    from_key = index[:m3]
    if np.bincount(from_key, minlength=len(keys)).max(initial=0) > 1:
        raise MeshError("the mesh is not edge-manifold and consistently oriented")
    h = len(keys)
    succ = np.full(h, -1, dtype=np.int64)
    succ[from_key] = index[m3:]
    has_pred = np.zeros(h, dtype=bool)
    has_pred[index[m3:]] = True
    # The twin of (a, b) at corner k is (b, a), the (a, c) of corner k + 1, and vice versa.
    next_corner = np.arange(m3).reshape(-1, 3)[:, [1, 2, 0]].ravel()  # no modulo: 13M at 2M
    twin = np.empty(h, dtype=np.int64)
    twin[from_key] = index[m3 + next_corner]
    twin[index[m3 + next_corner]] = from_key
    del next_corner
    # Fans: components of the successor links; a fan starts at its half-edge without a
    # predecessor (open) or at its smallest key (closed).
    links = sp.coo_matrix((np.ones(len(from_key)), (from_key, succ[from_key])), shape=(h, h))
    del index, from_key
    n_fans, fan = connected_components(links, directed=False)
    del links
    first = np.full(n_fans, h, dtype=np.int64)
    np.minimum.at(first, fan, np.arange(h))
    heads = np.flatnonzero(~has_pred)
    first[fan[heads]] = heads
    position = np.full(h, -1, dtype=np.int64)
    walk = first
    step = 0
    while len(walk):  # all fans at once, one step along each per round
        position[walk] = step
        walk = succ[walk]
        walk = walk[(walk >= 0) & (position[np.maximum(walk, 0)] < 0)]
        step += 1
    size = np.bincount(fan, minlength=n_fans)
    start = np.concatenate([[0], np.cumsum(size)])
    if (position >= 0).all():
        # Every half-edge has its place 0 .. size - 1 in its fan: ``np.lexsort((position,
        # fan))`` is the inverse of the permutation ``start[fan] + position``, one scatter.
        members = np.empty(h, dtype=np.int64)
        members[start[fan] + position] = np.arange(h)
    else:  # pragma: no cover - a fan walk that misses a half-edge
        members = np.lexsort((position, fan))
    return _Rotation(keys % n, twin, keys.astype(np.int64), fan, position, members, start)


def canonical_labelling(
    n_vertices: int, faces: NDArray[np.int64], *, source: int, first: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Breadth-first labelling in rotation order from the half-edge (source, first).

    Parameters
    ----------
    n_vertices : int
    faces : (m, 3) int64 ndarray
        Consistently oriented, edge-manifold, connected.
    source, first : int
        The starting half-edge: ``source`` gets label 0, and its neighbours are labelled in
        rotation order starting at ``first``.

    Returns
    -------
    order : (n,) int64 ndarray
        ``order[k]`` is the vertex labelled ``k``.
    parent : (n,) int64 ndarray
        The vertex that labelled each vertex (``-1`` for the source): a breadth-first tree.

    Raises
    ------
    MeshError
        If the mesh is not edge-manifold and oriented, or not every vertex is reached.

    Notes
    -----
    The traversal visits the vertices of a level in label order and each one's fan in rotation
    order from the half-edge it was entered by (of a boundary fan: to its end, then from its
    start).  Both are a rotation of the fan's order by the entry's place in it, so a whole
    level is done at once: every half-edge of the level's fans to an unlabelled vertex, sorted
    by (its vertex's label, its place after the entry); each new vertex is labelled at its first
    occurrence, entered by the twin of that half-edge.  The labels are those of the one-vertex-
    at-a-time traversal, bit for bit.
    """
    faces = np.asarray(faces, dtype=np.int64)
    return _labelling(_rotation(int(n_vertices), faces), int(n_vertices), source, first)


def _labelling(
    rot: _Rotation, n: int, source: int, first: int
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """:func:`canonical_labelling` in the rotation system ``rot`` of its faces."""
    key = source * n + first
    entry = int(np.searchsorted(rot.keys, key))
    if entry >= len(rot.keys) or rot.keys[entry] != key:
        raise ValueError(f"first={first} is not a neighbour of source={source}")
    parent = np.full(n, -2, dtype=np.int64)
    parent[source] = -1
    seen = np.empty(n, dtype=np.int64)  # scratch: first occurrence of a vertex in a level
    levels = [np.array([source], dtype=np.int64)]
    entries = np.array([entry], dtype=np.int64)
    while len(entries):
        fans = rot.fan[entries]
        size = rot.start[fans + 1] - rot.start[fans]
        owner = np.repeat(np.arange(len(entries)), size)  # the level's rank of each half-edge
        offset = np.arange(len(owner)) - np.repeat(np.cumsum(size) - size, size)
        # The ring of each entry: its fan rotated to start at the entry.
        place = (rot.position[entries][owner] + offset) % size[owner]
        half = rot.members[rot.start[fans][owner] + place]
        target = rot.target[half]
        fresh = parent[target] == -2
        half, target, owner = half[fresh], target[fresh], owner[fresh]
        # Already in (level rank, ring place) order: the first occurrence of each vertex
        # (written in reverse, the first occurrence's index is the one that stays).
        where = np.arange(len(target))
        seen[target[::-1]] = where[::-1]
        at = where[seen[target] == where]
        new = target[at]
        parent[new] = levels[-1][owner[at]]
        levels.append(new)
        entries = rot.twin[half[at]]
    order = np.concatenate(levels)
    if len(order) != n:
        raise MeshError(f"the mesh is not connected: {n - len(order)} vertices not reached")
    return order, parent


class _Sources(NamedTuple):
    """The candidate sources of a start, read off the smoothed copy."""

    tips: NDArray[np.int64]  # local maxima of the radial distance, the farthest vertex first
    runners: NDArray[np.int64]  # the next farthest vertices after it (its neighbours, mostly)
    margin: NDArray[np.float64]  # each runner's relative radial gap to the farthest vertex


def _sources(smooth: NDArray[np.float64], faces: NDArray[np.int64]) -> _Sources:
    radial = np.linalg.norm(smooth - area_centroid(smooth, faces), axis=1)
    edges, _ = unique_edges(faces)
    # A tip has no neighbour farther out (what ``radial >= `` its neighbours' maximum says,
    # without ``np.maximum.at``'s scattered updates: 2 s at 2M vertices).
    a, b = radial[edges[:, 0]], radial[edges[:, 1]]
    below = np.zeros(len(radial), dtype=bool)
    below[edges[a < b, 0]] = True
    below[edges[b < a, 1]] = True
    tips = np.flatnonzero(~below)
    tips = tips[np.argsort(-radial[tips], kind="stable")][:TIPS]
    far = int(np.argmax(radial))  # the farthest vertex, even if a neighbour ties with it
    tips = np.concatenate([[far], tips[tips != far]])[:TIPS].astype(np.int64)
    used = np.flatnonzero(np.bincount(faces.ravel(), minlength=len(smooth)))
    count = min(TIPS + 1, len(used))
    top = used[np.argpartition(-radial[used], count - 1)[:count]]
    top = top[np.lexsort((top, -radial[top]))]
    runners = top[top != far][:TIPS].astype(np.int64)
    margin = 1.0 - radial[runners] / radial[far] if radial[far] > 0 else np.ones(len(runners))
    return _Sources(tips, runners, margin)


def _edges_from(
    smooth: NDArray[np.float64], faces: NDArray[np.int64], source: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The source's neighbours, longest smoothed edge first, and the edges' lengths."""
    nbrs = np.unique(faces[np.flatnonzero(faces.ravel() == source) // faces.shape[1]])
    nbrs = nbrs[nbrs != source]
    length = np.linalg.norm(smooth[nbrs] - smooth[source], axis=1)
    order = np.argsort(-length, kind="stable")
    return nbrs[order], length[order]


def _near_ties(
    smooth: NDArray[np.float64], faces: NDArray[np.int64], sources: _Sources
) -> tuple[int, ...]:
    out = []
    for t, source in enumerate(sources.tips.tolist()):
        _, length = _edges_from(smooth, faces, source)
        if len(length) > 1 and length[1] >= (1.0 - EDGE_MARGIN) * length[0]:
            out.append(TIPS + t)
    out.extend(2 * TIPS + j for j in np.flatnonzero(sources.margin <= RADIAL_MARGIN).tolist())
    return tuple(out)


def _start(
    smooth: NDArray[np.float64], faces: NDArray[np.int64], rank: int, sources: _Sources
) -> tuple[int, int]:
    """The starting half-edge of ``rank`` (see :func:`stable_cut`)."""
    family, j = divmod(rank, TIPS)
    pool = sources.runners if family == 2 else sources.tips
    if not 0 <= rank < 3 * TIPS or j >= len(pool):
        raise MeshError(f"the surface has {len(pool)} such sources, no start of rank {rank}")
    source = int(pool[j])
    nbrs, _ = _edges_from(smooth, faces, source)
    alternative = 1 if family == 1 else 0
    if alternative >= len(nbrs):
        raise MeshError(f"no start of rank {rank}: the tip has {len(nbrs)} neighbours")
    return source, int(nbrs[alternative])


def cut_start(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    steps: int = 50,
    lam: float = 0.5,
    rank: int = 0,
) -> tuple[tuple[int, int], tuple[int, ...]]:
    """The starting half-edge :func:`stable_cut` would use, and its ``near_ties``.

    The cut and the labelling depend on the geometry through this half-edge only.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    smooth, sources, near_ties = _smoothed_sources(vertices, faces, steps=steps, lam=lam)
    return _start(smooth, faces, rank, sources), near_ties


#: The last few meshes' smoothed copies and sources (:func:`_smoothed_sources`).
_MEMO: OrderedDict[tuple, tuple[NDArray[np.float64], _Sources, tuple[int, ...]]] = OrderedDict()
_MEMO_SIZE = 2
_MEMO_LOCK = threading.Lock()


def _smoothed_sources(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, steps: int, lam: float
) -> tuple[NDArray[np.float64], _Sources, tuple[int, ...]]:
    """The smoothed copy, its candidate sources and near-ties, computed once per mesh.

    A blind reader asks for the start of several ranks of one mesh, and the embedder's
    read-back asks :func:`meshwm.gim.tutte.restart_map` and then, where the start moved,
    :func:`stable_cut` of the same mesh: a pure function of the arrays, so the last
    :data:`_MEMO_SIZE` meshes' results are kept (by a digest of their bytes).
    """
    key = (*arrays_key(vertices, faces), int(steps), float(lam))
    with _MEMO_LOCK:
        if key in _MEMO:
            _MEMO.move_to_end(key)
            return _MEMO[key]
        pending = list(_AHEAD)
    for ahead in pending:  # made ahead in a second thread (smoothing_ahead): waited for
        if ahead.key.exception() is None and ahead.key.result() == key:
            try:
                return ahead.found.result()
            except Exception:  # made here instead (where it fails again, it raises)
                break
    return _remember(key, smoothed_copy(vertices, faces, steps=steps, lam=lam), faces)


class _Ahead(NamedTuple):
    key: Future[tuple]
    found: Future[tuple[NDArray[np.float64], _Sources, tuple[int, ...]]]


#: The meshes whose smoothed copies are being made ahead (:func:`smoothing_ahead`).
_AHEAD: list[_Ahead] = []


@contextmanager
def smoothing_ahead(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], *, steps: int = 50, lam: float = 0.5
) -> Iterator[None]:
    """Make the smoothed copy, sources and near-ties of a mesh in a second thread while the
    ``with`` block runs: a :func:`cut_start` of the same arrays inside the block waits for them
    instead of making them again (leaving the block waits for the thread).

    The surface's cleaning (:func:`meshwm.mesh.clean.clean_mesh`) returns most meshes as they
    were given, and the smoothing is made of the cleaned mesh: started on the input beside the
    cleaning, it is ready, or nearly, when the cut asks for it.  Where the cleaning changed
    the mesh, it was work on the second core only, and is not used.
    """
    ahead = _Ahead(Future(), Future())

    def run() -> None:
        try:
            key = (*arrays_key(vertices, faces), int(steps), float(lam))
        except BaseException as exc:
            ahead.key.set_exception(exc)
            ahead.found.set_exception(exc)
            return
        ahead.key.set_result(key)
        try:
            smooth = smoothed_copy(vertices, faces, steps=steps, lam=lam)
            ahead.found.set_result(_remember(key, smooth, faces))
        except BaseException as exc:
            ahead.found.set_exception(exc)

    with _MEMO_LOCK:
        _AHEAD.append(ahead)
    try:
        with beside(run):
            yield
    finally:
        with _MEMO_LOCK:
            _AHEAD.remove(ahead)


def _remember(
    key: tuple, smooth: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float64], _Sources, tuple[int, ...]]:
    """A mesh's smoothed copy (made read-only) with its sources and near-ties, memoised
    under ``key`` (:func:`_smoothed_sources`, :func:`smoothed_near`)."""
    smooth.flags.writeable = False
    sources = _sources(smooth, faces)
    found = (smooth, sources, _near_ties(smooth, faces, sources))
    with _MEMO_LOCK:
        _MEMO[key] = found
        while len(_MEMO) > _MEMO_SIZE:
            _MEMO.popitem(last=False)
    return found


#: :func:`smoothed_near` computes the rows a change reaches only where they are at most this
#: fraction of the mesh (its cone is up to twice ``steps`` rings around the changed rows).
_NEAR_FRACTION = 0.5


def smoothed_near(
    base: NDArray[np.float64],
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    steps: int = 50,
    lam: float = 0.5,
) -> bool:
    """Memoise the smoothed copy, sources and near-ties of ``vertices`` (what
    :func:`cut_start` asks for), computed from the memoised copy of ``base`` (the same faces)
    where the two differ in a few rows; True where it did.

    Each step's row is a sum of its terms in their stored order, so a row whose ``k``-ring
    holds no changed row comes out of ``k`` steps with the bits it had: after ``steps`` steps
    only the rows within ``steps`` rings of a change differ, and those are computed from the
    new positions within ``2 steps`` rings, each step on the rows the next one reads (a cone
    that narrows by a ring a step).  The result is bit for bit :func:`smoothed_copy` of
    ``vertices``.  (The embedder's bump that puts a cut's start back moves the ``steps``-ring
    of two vertices: at 537k vertices the check of the bumped mesh took a whole smoothing,
    1.3 s.)

    Returns False, memoising nothing, where ``base``'s copy is not memoised, the arrays do not
    match, or the cone is over :data:`_NEAR_FRACTION` of the mesh.
    """
    base = np.asarray(base, dtype=np.float64)
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if base.shape != vertices.shape:
        return False
    with _MEMO_LOCK:
        found = _MEMO.get((*arrays_key(base, faces), int(steps), float(lam)))
    if found is None:
        return False
    n = len(vertices)
    changed = np.flatnonzero(np.any(vertices != base, axis=1))
    if len(changed) == 0:
        return False
    order, local = _step(n, faces, lam)
    rank = np.arange(n) if order is None else np.empty(n, dtype=np.int64)
    if order is not None:
        rank[order] = np.arange(n)
    reach = 2 * int(steps)
    # Rings of the connectivity both ways: a boundary row reads its boundary neighbours only,
    # and a ring counted both ways is never farther than the one a step reads.
    rings = dijkstra(
        local,
        directed=False,
        indices=rank[changed],
        unweighted=True,
        min_only=True,
        limit=reach + 0.5,
    )
    cone = np.flatnonzero(np.isfinite(rings))
    if len(cone) > _NEAR_FRACTION * n:
        return False
    # The cone's rows nearest first: the rows a step computes are a prefix of them.
    cone = cone[np.argsort(rings[cone], kind="stable")]
    depth = rings[cone].astype(np.int64)
    rows = local[cone]
    x_new = vertices if order is None else vertices[order]
    current = np.zeros((n, 3))
    current[cone] = x_new[cone]
    ahead = np.empty((n, 3))
    for k in range(1, int(steps) + 1):
        m = int(np.searchsorted(depth, reach - k, side="right"))
        prefix = sp.csr_matrix(
            (rows.data[: rows.indptr[m]], rows.indices[: rows.indptr[m]], rows.indptr[: m + 1]),
            shape=(m, n),
        )
        ahead[cone[:m]] = prefix @ current
        current, ahead = ahead, current
    reached = cone[: int(np.searchsorted(depth, reach - int(steps), side="right"))]
    smooth = np.array(found[0])
    smooth[reached if order is None else order[reached]] = current[reached]
    _remember((*arrays_key(vertices, faces), int(steps), float(lam)), smooth, faces)
    return True


def _tree_path(parent: NDArray[np.int64], tip: int) -> NDArray[np.int64]:
    path = [tip]
    while parent[path[-1]] >= 0:
        path.append(int(parent[path[-1]]))
    return np.asarray(path, dtype=np.int64)


def stable_cut(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    steps: int = 50,
    lam: float = 0.5,
    rank: int = 0,
) -> StableCut:
    """Cut the mesh to a disk in its canonical labelling (see the module notes).

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        Connected, consistently oriented, edge-manifold triangles.
    steps, lam
        The smoothing of the copy that picks the starting half-edge (:func:`smoothed_copy`).
    rank : int, optional
        Start from the ``rank``-th farthest tip (a local maximum of the distance to the
        centroid on the smoothed copy) instead of the farthest: where two tips are nearly tied,
        the mark, noise or a few flips can swap them, and a reader then tries the runner-up
        (:mod:`meshwm.readers.surface`).  Ranks ``TIPS .. 2 * TIPS - 1`` start from tip
        ``rank - TIPS`` along its second longest smoothed edge instead of its longest: where
        the two are a near-tie (``StableCut.near_ties``) the mark can swap them too.  Ranks
        ``2 * TIPS .. 3 * TIPS - 1`` start from the second, third, ... farthest vertex (along
        its longest edge): where the farthest vertex has a neighbour within
        :data:`RADIAL_MARGIN` of it, smoothing or quantisation can swap the two.

    Returns
    -------
    StableCut

    Raises
    ------
    MeshError
        If the mesh is not connected, oriented and edge-manifold, or the cut is not a disk.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    # The rotation system depends on the faces alone: found beside the smoothed copy.
    with beside(_rotation, len(vertices), faces) as rotation:
        (source, first), near_ties = cut_start(vertices, faces, steps=steps, lam=lam, rank=rank)
        order, parent = _labelling(rotation.result(), len(vertices), source, first)
    label = np.empty_like(order)
    label[order] = np.arange(len(order))
    if euler_characteristic(len(vertices), faces) != 2:
        canonical = igl.cut_to_disk(canonical_faces(faces, label))
        paths = [order[np.asarray(c, dtype=np.int64)] for c in canonical]
    else:  # connected and closed genus 0: igl.cut_to_disk leaves it uncut (igea: after 1.4 s)
        paths = [_tree_path(parent, int(order[-1]))]
        if len(paths[0]) == 2:  # one edge does not open a sphere: on to the source's first
            paths = [order[[-1, 0, 1]]]
    edges = np.sort(path_edges(paths), axis=1)
    edges = np.unique(edges, axis=0) if len(edges) else edges.reshape(0, 2)
    return StableCut(cut_open(vertices, faces, paths), edges, order, near_ties)
