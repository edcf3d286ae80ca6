"""Attacks that flip edges and move no vertex: nearly flat edges, quads split the other way.

What clean-up tools and quad-to-triangle exporters do to the connectivity without changing the
shape: ``flip_edges`` flips nearly flat edges one after another (each on the current mesh),
``retriangulate`` pairs nearly coplanar triangles into disjoint quads and splits a fraction of
them along their other diagonal.  Vertices, face count, orientation and the Euler characteristic
are kept.  :func:`interior_pairs` (edges with their two faces) is shared with
:mod:`~meshwm.attacks.seams`.  NumPy only.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks.params import Mesh, check_options
from meshwm.mesh.clean import unique_edges

__all__ = [
    "QUAD_DIHEDRAL",
    "EdgePairs",
    "FlipResult",
    "flat_edges",
    "flip_edges",
    "flip_flat_edges",
    "interior_pairs",
    "retriangulate",
]

#: Largest dihedral angle (degrees) of the quads that ``retriangulate`` re-splits.
QUAD_DIHEDRAL = 10.0


class FlipResult(NamedTuple):
    """Result of :func:`flip_flat_edges`.

    Attributes
    ----------
    faces : (m, 3) int64 ndarray
        The faces after the flips (same count and order; a flipped pair is rewritten in place).
    removed : (k, 2) int64 ndarray
        The flipped edges (sorted vertex pairs), in the order they were flipped.
    added : (k, 2) int64 ndarray
        The edge each flip created (sorted pairs), row by row with ``removed``.
    candidates : int
        Number of edges that could be flipped in the input (:func:`flat_edges`).
    """

    faces: NDArray[np.int64]
    removed: NDArray[np.int64]
    added: NDArray[np.int64]
    candidates: int


# --- the interior edges and their two faces ---------------------------------------------------


class EdgePairs(NamedTuple):
    """Interior edges of a mesh, each with its two faces: result of :func:`interior_pairs`.

    Row ``k`` is the edge ``a[k] -> b[k]`` of face ``fa[k]`` (third corner ``c[k]``), traversed
    ``b[k] -> a[k]`` by face ``fb[k]`` (third corner ``d[k]``), rows in increasing order of
    their edge's key; ``keys`` lists every edge of the mesh, interior or not, as
    ``lo * n + hi`` (``lo < hi``, n the vertex count), sorted.
    """

    a: NDArray[np.int64]
    b: NDArray[np.int64]
    fa: NDArray[np.int64]
    fb: NDArray[np.int64]
    c: NDArray[np.int64]  # third vertex of fa
    d: NDArray[np.int64]  # third vertex of fb
    keys: NDArray[np.int64]  # sorted keys of every edge of the mesh (lo * n + hi)


def interior_pairs(n: int, f: NDArray[np.int64]) -> EdgePairs:
    """The edges of exactly two faces that traverse them in opposite directions.

    Faces with a repeated corner take part in none.  ``n`` is the vertex count.
    """
    edges, inverse = unique_edges(f)
    count = np.bincount(inverse, minlength=len(edges))
    order = np.argsort(inverse, kind="stable")
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    two = np.flatnonzero(count == 2)
    h1, h2 = order[start[two]], order[start[two] + 1]  # corner-edges 3 * face + corner
    tail = f.ravel()
    degenerate = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])
    ok = (tail[h1] != tail[h2]) & ~degenerate[h1 // 3] & ~degenerate[h2 // 3]
    h1, h2 = h1[ok], h2[ok]
    third = f[h1 // 3, (h1 % 3 + 2) % 3], f[h2 // 3, (h2 % 3 + 2) % 3]
    keys = edges[:, 0] * n + edges[:, 1]
    return EdgePairs(tail[h1], tail[h2], h1 // 3, h2 // 3, third[0], third[1], keys)


def _unit_normals(v: NDArray[np.float64], tri: NDArray[np.int64]) -> NDArray[np.float64]:
    n = np.cross(v[tri[:, 1]] - v[tri[:, 0]], v[tri[:, 2]] - v[tri[:, 0]])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return n / length  # NaN for a zero-area triangle: every comparison below is False


def _flippable(
    v: NDArray[np.float64], faces: NDArray[np.int64], pairs: EdgePairs, max_dihedral: float
) -> NDArray[np.bool_]:
    """Which pairs are flat (dihedral < max) and flip without folding or doubling an edge."""
    a, b, c, d = pairs.a, pairs.b, pairs.c, pairs.d
    normals = _unit_normals(v, faces)
    n1, n2 = normals[pairs.fa], normals[pairs.fb]
    cos_limit = math.cos(math.radians(max_dihedral))
    with np.errstate(invalid="ignore"):
        ok = np.flatnonzero((np.einsum("ij,ij->i", n1, n2) > cos_limit) & (c != d))
    a, b, c, d, n1, n2 = a[ok], b[ok], c[ok], d[ok], n1[ok], n2[ok]
    unfolded = np.ones(len(ok), dtype=bool)
    with np.errstate(invalid="ignore"):
        for new in (
            _unit_normals(v, np.stack([a, d, c], 1)),
            _unit_normals(v, np.stack([d, b, c], 1)),
        ):
            for old in (n1, n2):
                unfolded &= np.einsum("ij,ij->i", new, old) > 0
    new_keys = np.minimum(c, d) * v.shape[0] + np.maximum(c, d)
    where = np.clip(np.searchsorted(pairs.keys, new_keys), 0, len(pairs.keys) - 1)
    result = np.zeros(len(pairs.a), dtype=bool)
    result[ok] = unfolded & (pairs.keys[where] != new_keys)
    return result


def flat_edges(vertices: NDArray, faces: NDArray, *, max_dihedral: float = 10.0) -> NDArray:
    """The edges :func:`flip_edges` may flip: interior, flat and flippable in the input.

    An edge qualifies when exactly two faces share it, traversing it in opposite directions
    (consistently oriented, no repeated corner), the angle between their normals is below
    ``max_dihedral`` degrees, the two opposite vertices are not already joined by an edge, and
    both new faces' normals lie within 90° of both old faces' normals (no fold, no zero area).

    Returns
    -------
    (k, 2) int64 ndarray
        The edges as sorted vertex pairs, in lexicographic order.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> flat_edges(v, [[0, 1, 2], [0, 2, 3]]).tolist()
    [[0, 2]]
    """
    max_dihedral = check_options("flip_edges", max_dihedral=max_dihedral)["max_dihedral"]
    v, f = check_mesh(vertices, faces)
    pairs = interior_pairs(len(v), f)
    ok = _flippable(v, f, pairs, max_dihedral)
    edges = np.stack([np.minimum(pairs.a, pairs.b), np.maximum(pairs.a, pairs.b)], axis=1)[ok]
    return edges[np.lexsort(edges.T[::-1])]


# --- flips, one after another on the current mesh -------------------------------------------


def _normal(p: list[float], q: list[float], r: list[float]) -> tuple[float, float, float]:
    ux, uy, uz = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    wx, wy, wz = r[0] - p[0], r[1] - p[1], r[2] - p[2]
    return uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx


def _cos(n1: tuple[float, float, float], n2: tuple[float, float, float]) -> float:
    norm = math.sqrt(
        (n1[0] ** 2 + n1[1] ** 2 + n1[2] ** 2) * (n2[0] ** 2 + n2[1] ** 2 + n2[2] ** 2)
    )
    if norm == 0.0:
        return -2.0  # a zero-area triangle never qualifies
    return (n1[0] * n2[0] + n1[1] * n2[1] + n1[2] * n2[2]) / norm


class _Flipper:
    """The faces, edge -> (face, face) and the edges ever present, updated flip by flip.

    The input's edges are sorted key arrays (looked up by binary search, nothing built per
    edge); the edges a flip touches go to small overlay dicts.  An edge removed by a flip
    stays "present", so no later flip re-creates it: every flip removes one edge of the input
    and adds one that the input did not have.
    """

    def __init__(self, v: NDArray[np.float64], f: NDArray[np.int64], pairs: EdgePairs) -> None:
        self.n = len(v)
        self.vertices = v
        self.faces = f.copy()
        lo, hi = np.minimum(pairs.a, pairs.b), np.maximum(pairs.a, pairs.b)
        self._pair_keys = lo * self.n + hi  # increasing, as the rows of ``pairs``
        self._pair_faces = np.stack([pairs.fa, pairs.fb], axis=1)
        self._all_keys = pairs.keys
        self._changed: dict[int, tuple[int, int] | None] = {}  # None: the edge was flipped
        self._added: set[int] = set()

    def _key(self, p: int, q: int) -> int:
        return min(p, q) * self.n + max(p, q)

    def _faces_of(self, key: int) -> tuple[int, int] | None:
        """The two faces of an interior edge now (None: boundary, non-manifold or gone)."""
        if key in self._changed:
            return self._changed[key]
        i = int(np.searchsorted(self._pair_keys, key))
        if i < len(self._pair_keys) and self._pair_keys[i] == key:
            fa, fb = self._pair_faces[i].tolist()
            return fa, fb
        return None

    def _present(self, key: int) -> bool:
        if key in self._added:
            return True
        i = int(np.searchsorted(self._all_keys, key))
        return i < len(self._all_keys) and bool(self._all_keys[i] == key)

    def _replace(self, p: int, q: int, old: int, new: int) -> None:
        key = self._key(p, q)
        both = self._faces_of(key)
        if both is not None:  # boundary and non-manifold edges are not tracked
            self._changed[key] = (
                new if both[0] == old else both[0],
                new if both[1] == old else both[1],
            )

    def flip(self, p: int, q: int, cos_limit: float) -> tuple[int, int] | None:
        """Flip edge p-q if it is still flat and flippable; the new edge (sorted) or None."""
        both = self._faces_of(self._key(p, q))
        if both is None:
            return None
        fa, fb = both
        row = self.faces[fa].tolist()
        i = row.index(p)
        if row[(i + 1) % 3] != q:  # orient p -> q in face fa
            p, q = q, p
            i = row.index(p)
        c = row[(i + 2) % 3]
        d = next(x for x in self.faces[fb].tolist() if x != p and x != q)
        if c == d or self._present(self._key(c, d)):
            return None
        vp, vq, vc, vd = self.vertices[[p, q, c, d]].tolist()
        n1, n2 = _normal(vp, vq, vc), _normal(vq, vp, vd)
        m1, m2 = _normal(vp, vd, vc), _normal(vd, vq, vc)
        if _cos(n1, n2) <= cos_limit or min(_cos(m, o) for m in (m1, m2) for o in (n1, n2)) <= 0:
            return None
        self.faces[fa, (i + 1) % 3] = d  # (p, q, c) -> (p, d, c)
        self.faces[fb, self.faces[fb].tolist().index(p)] = c  # (q, p, d) -> (q, c, d)
        self._changed[self._key(p, q)] = None
        self._changed[self._key(c, d)] = (fa, fb)
        self._replace(p, d, fb, fa)
        self._replace(q, c, fa, fb)
        self._added.add(self._key(c, d))
        return min(c, d), max(c, d)

    def flip_in_order(
        self, edges: NDArray[np.int64], count: int, cos_limit: float
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Try ``edges`` in order until ``count`` flipped; the removed and the added edges."""
        removed: list[tuple[int, int]] = []
        added: list[tuple[int, int]] = []
        # A few rows at a time: tolist() of all 400k candidates would cost more than 1,000 flips.
        chunks = (edges[s : s + 1024].tolist() for s in range(0, len(edges), 1024))
        for p, q in (row for chunk in chunks for row in chunk):
            if len(removed) >= count:
                break
            new = self.flip(p, q, cos_limit)
            if new is not None:
                removed.append((min(p, q), max(p, q)))
                added.append(new)
        as_pairs = np.array(removed + added, dtype=np.int64).reshape(-1, 2)
        return as_pairs[: len(removed)], as_pairs[len(removed) :]


def flip_flat_edges(
    vertices: NDArray,
    faces: NDArray,
    *,
    seed: int = 0,
    count: int = 10,
    max_dihedral: float = 10.0,
) -> FlipResult:
    """:func:`flip_edges` with what it did: the flipped and created edges, the candidates.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seed : int
        Order in which the candidate edges are tried (NumPy ``default_rng``).
    count : int
        Number of flips wanted, >= 0.
    max_dihedral : float
        Largest angle between the two faces' normals of a flipped edge, degrees, in (0, 180).

    Returns
    -------
    FlipResult
        ``len(result.removed)`` is the number of flips done: ``count``, or fewer when fewer
        edges could be flipped.

    Notes
    -----
    The candidates are :func:`flat_edges` of the input, tried once each in a seeded random
    order.  When its turn comes an edge is checked again on the current mesh (a neighbour's
    flip may have changed its two faces): still flat, the opposite vertices not joined, no
    fold.  Faces ``(p, q, c)`` and ``(q, p, d)`` become ``(p, d, c)`` and ``(q, c, d)`` in
    the same two rows, the two kept corners of each in their places: orientation is kept.  No
    flip re-creates an edge an earlier flip removed, so the output's edges differ from the
    input's in exactly ``len(removed)`` edges.
    """
    opts = check_options("flip_edges", count=count, max_dihedral=max_dihedral)
    v, f = check_mesh(vertices, faces)
    pairs = interior_pairs(len(v), f)
    ok = _flippable(v, f, pairs, opts["max_dihedral"])
    a, b = pairs.a[ok], pairs.b[ok]
    candidates = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    order = np.random.default_rng(seed).permutation(len(candidates))
    flipper = _Flipper(v, f, pairs)
    cos_limit = math.cos(math.radians(opts["max_dihedral"]))
    removed, added = flipper.flip_in_order(candidates[order], opts["count"], cos_limit)
    return FlipResult(flipper.faces, removed, added, len(candidates))


def flip_edges(
    vertices: NDArray,
    faces: NDArray,
    *,
    seed: int = 0,
    count: int = 10,
    max_dihedral: float = 10.0,
) -> Mesh:
    """Flip ``count`` random nearly flat interior edges, one after another (clean-up tools).

    An edge is flipped when the angle between its two faces' normals is below
    ``max_dihedral`` degrees (in (0, 180)), its two opposite vertices are not already joined
    and neither new face folds over; faces keep their orientation, vertices do not move.
    With fewer such edges than ``count`` (>= 0), all that can be are flipped:
    :func:`flip_flat_edges` runs the same flips and says how many (``len(result.removed)``).

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> flip_edges(v, [[0, 1, 2], [0, 2, 3]])[1].tolist()  # diagonal 0-2 becomes 1-3
    [[3, 1, 2], [0, 1, 3]]
    """
    result = flip_flat_edges(vertices, faces, seed=seed, count=count, max_dihedral=max_dihedral)
    return check_mesh(vertices, faces)[0], result.faces


def retriangulate(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, fraction: float = 0.2
) -> Mesh:
    """Quads re-triangulated the other way: flip the diagonal of ``fraction`` of flat face pairs.

    The faces are paired into disjoint quads: the :func:`flat_edges` with dihedral below
    :data:`QUAD_DIHEDRAL` (10°), taken in a seeded random order, each joining two faces not
    yet in a quad (a greedy maximal matching).  ``round(fraction · quads)`` of them (``fraction``
    in (0, 1]), drawn at random, get the other diagonal, with the checks of
    :func:`flip_flat_edges` (one is skipped, and the next quad tried, if an earlier flip
    already made its new diagonal).  Vertices, face count and the Euler characteristic are
    kept; faces keep their orientation.
    """
    frac = check_options("retriangulate", fraction=fraction)["fraction"]
    v, f = check_mesh(vertices, faces)
    pairs = interior_pairs(len(v), f)
    ok = np.flatnonzero(_flippable(v, f, pairs, QUAD_DIHEDRAL))
    rng = np.random.default_rng(seed)
    used = bytearray(len(f))
    quads = []
    order = ok[rng.permutation(len(ok))]
    both = zip(order.tolist(), pairs.fa[order].tolist(), pairs.fb[order].tolist(), strict=True)
    for k, fa, fb in both:
        if not (used[fa] or used[fb]):
            used[fa] = used[fb] = 1
            quads.append(k)
    chosen = np.array(quads, dtype=np.int64)[rng.permutation(len(quads))]
    a, b = pairs.a[chosen], pairs.b[chosen]
    edges = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    flipper = _Flipper(v, f, pairs)
    flipper.flip_in_order(edges, round(frac * len(quads)), math.cos(math.radians(QUAD_DIHEDRAL)))
    return v, flipper.faces
