"""Read the geometry-image grid back from the connectivity of a received mesh.

Blind extraction gets a mesh and nothing else: no vertex order (files are re-indexed, an STL
round trip un-indexes and re-welds every vertex), no side file.  What survives is the
connectivity, and meshwm writes that connectivity itself (:func:`meshwm.geometry_image.grid_faces`):
two triangles per grid cell with known diagonals, welded along the cut seams, and a *fiducial*
at the centre sample (N/2, N/2): three flipped diagonals that give it 5 neighbours with 5, 5, 6,
6 and 8 neighbours of their own.

:func:`recover_grid` finds which vertex is grid sample (i, j):

1. **N** from the face count: the grid has 2 (N-1)^2 triangles, a few fewer where a welded cut
   end collapsed some; N is the power of two that fits.
2. **Seeds**: every vertex whose one-ring matches the fiducial pattern; its 8-neighbour is
   sample (N/2 + 1, N/2 - 1).  On a mesh meshwm wrote there is one; seam vertices can match by
   chance, so each candidate is only a hypothesis.
3. **Propagation by oriented triangles**: when two samples p, q of a grid triangle (p, q, r)
   are known as vertices u, v, the one face of the oriented manifold mesh with the directed
   edge u -> v is that triangle, and its third vertex is sample r.  This needs no notion of
   "interior" or "seam": grid triangles on both sides of a welded seam are still distinct faces
   with distinct directed edges, so the walk never confuses the two sides.
4. **Verification**: a hypothesis is accepted only if every sample got a vertex, no sample got
   two, every vertex is some sample, and every face of the mesh is exactly one grid triangle.
   A wrong seed fails this (it walks off the grid or meets a contradiction).  If no hypothesis
   holds, the faces are tried reversed (a file whose winding was flipped).  The fiducial has
   no symmetry, so a flipped file never verifies as some transformed grid.

Connectivity fixes the grid completely, including which of the eight symmetries of the square
is meant; the geometry is not used at all, so any pose, scale or vertex order reads the same.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .geometry_image import grid_faces

__all__ = ["GridError", "RecoveredGrid", "recover_grid"]

_MIN_SIZE = 8
_MAX_SIZE = 4096


class GridError(ValueError):
    """The mesh is not a geometry-image mesh written by meshwm (no grid could be read)."""


class RecoveredGrid(NamedTuple):
    """A grid read from connectivity.

    Attributes
    ----------
    n : int
        The grid size N.
    index : (N, N) int64 ndarray
        Vertex index of each grid sample (welded samples share a vertex).
    gim : (N, N, 3) float64 ndarray
        The geometry image: ``vertices[index]``.
    hypotheses : int
        Seeds tried (each a full propagation) before one verified.
    """

    n: int
    index: NDArray[np.int64]
    gim: NDArray[np.float64]
    hypotheses: int


def _fiducial_candidates(n_vertices: int, faces: NDArray[np.int64]) -> list[tuple[int, int]]:
    """(centre, eight-neighbour) vertex pairs whose one-rings match the fiducial pattern.

    The fiducial and its ring are interior vertices, whose valence is their face count.
    """
    valence = np.bincount(faces.ravel(), minlength=n_vertices)
    centre = valence == 5
    near = faces[centre[faces].any(axis=1)]
    # (centre, neighbour) pairs from the faces around each valence-5 vertex.
    pairs = np.concatenate([near[:, [k, (k + d) % 3]] for k in range(3) for d in (1, 2)])
    pairs = pairs[centre[pairs[:, 0]]]
    pairs = np.unique(pairs[:, 0] * n_vertices + pairs[:, 1])
    c, nb = np.divmod(pairs, n_vertices)
    out = []
    bounds = np.flatnonzero(np.diff(c)) + 1
    for cc, ring in zip(np.split(c, bounds), np.split(nb, bounds), strict=True):
        vals = valence[ring]
        if len(ring) == 5 and np.sort(vals).tolist() == [5, 5, 6, 6, 8]:
            out.append((int(cc[0]), int(ring[np.argmax(vals)])))
    return out


class _Lookup:
    """Directed edge (u, v) -> third vertex of the face that has it, for an oriented mesh."""

    def __init__(self, n_vertices: int, faces: NDArray[np.int64]):
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        keys = np.concatenate([a, b, c]) * n_vertices + np.concatenate([b, c, a])
        third = np.concatenate([c, a, b])
        face = np.tile(np.arange(len(faces)), 3)
        order = np.argsort(keys, kind="stable")
        self.keys, self.third, self.face = keys[order], third[order], face[order]
        # A directed edge used twice means the mesh is not an oriented manifold there: such
        # edges never answer, so a propagation through them fails verification.
        dup = np.zeros(len(order), dtype=bool)
        dup[1:] = self.keys[1:] == self.keys[:-1]
        dup[:-1] |= dup[1:]
        self.third = np.where(dup, -1, self.third)
        self.n_vertices = n_vertices

    def __call__(
        self, u: NDArray[np.int64], v: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        key = u * self.n_vertices + v
        pos = np.searchsorted(self.keys, key)
        pos = np.minimum(pos, len(self.keys) - 1)
        hit = self.keys[pos] == key
        return np.where(hit, self.third[pos], -1), np.where(hit, self.face[pos], -1)


class _GridTable:
    """Every (p, q, r) corner rotation of the grid triangles, sorted for the walk."""

    def __init__(self, n: int):
        t = grid_faces(n)
        rows = np.concatenate([t, t[:, [1, 2, 0]], t[:, [2, 0, 1]]])
        i, j = np.divmod(np.arange(n * n), n)
        border = (i == 0) | (j == 0) | (i == n - 1) | (j == n - 1)
        self.n, self.triangles, self.border = n, t, border
        # Interior rows: p, q and r off the border.  Border cells are the only ones a weld can
        # collapse, so the interior walk meets nothing but live triangles.
        inner = rows[~border[rows].any(axis=1)]
        owner = np.concatenate([inner[:, 0], inner[:, 1]])
        row_id = np.tile(np.arange(len(inner)), 2)
        order = np.argsort(owner, kind="stable")
        self.inner, self.row_of = inner, row_id[order]
        self.start = np.searchsorted(owner[order], np.arange(n * n + 1))
        # Border rows (r on the border), with their trust: how many of p, q are interior.
        outer = rows[border[rows[:, 2]]]
        self.outer = outer
        self.trust = (~border[outer[:, 0]]).astype(int) + (~border[outer[:, 1]]).astype(int)
        # Each border sample's two neighbours along the perimeter of the square.
        ring = np.concatenate(
            [
                np.arange(n),  # row 0, left to right
                np.arange(1, n) * n + n - 1,  # column N-1, downwards
                (n - 1) * n + np.arange(n - 2, -1, -1),  # row N-1, right to left
                np.arange(n - 2, 0, -1) * n,  # column 0, upwards
            ]
        )
        self.prev = np.full(n * n, -1, dtype=np.int64)
        self.next = np.full(n * n, -1, dtype=np.int64)
        self.prev[ring] = np.roll(ring, 1)
        self.next[ring] = np.roll(ring, -1)

    def inner_rows_touching(self, positions: NDArray[np.int64]) -> NDArray[np.int64]:
        lo, hi = self.start[positions], self.start[positions + 1]
        counts = hi - lo
        idx = np.repeat(lo - np.cumsum(counts) + counts, counts) + np.arange(counts.sum())
        return self.inner[self.row_of[idx]]


@functools.lru_cache(maxsize=4)
def _grid_table(n: int) -> _GridTable:
    return _GridTable(n)


def _assign(index: NDArray[np.int64], r: NDArray, w: NDArray) -> NDArray[np.int64] | None:
    """Set index[r] = w for new samples; None on a contradiction; the samples set."""
    known = index[r]
    if np.any((known >= 0) & (known != w)):
        return None  # a sample reached as two different vertices
    r, w = r[known < 0], w[known < 0]
    order = np.argsort(r, kind="stable")
    r, w = r[order], w[order]
    same = r[1:] == r[:-1]
    if np.any(same & (w[1:] != w[:-1])):
        return None
    first = np.ones(len(r), dtype=bool)
    first[1:] = ~same
    index[r[first]] = w[first]
    return r[first]


def _step(index: NDArray[np.int64], rows: NDArray[np.int64], lookup: _Lookup):
    """Third vertices for the rows whose p, q are known (distinct) and r is not."""
    u, v = index[rows[:, 0]], index[rows[:, 1]]
    rows = rows[(u >= 0) & (v >= 0) & (u != v) & (index[rows[:, 2]] < 0)]
    third, _ = lookup(index[rows[:, 0]], index[rows[:, 1]])
    return rows[third >= 0, 2], third[third >= 0]


def _propagate(
    n: int, table: _GridTable, lookup: _Lookup, seed: tuple[int, int], n_faces: int
) -> NDArray[np.int64] | None:
    """Walk the grid from the fiducial seed; the sample -> vertex map, or None if it fails."""
    c = n // 2
    index = np.full(n * n, -1, dtype=np.int64)
    index[c * n + c] = seed[0]
    index[(c + 1) * n + c - 1] = seed[1]
    # 1. The interior, breadth first from the seed.
    frontier: NDArray[np.int64] | None = np.array([c * n + c, (c + 1) * n + c - 1])
    while frontier is not None and len(frontier):
        r, w = _step(index, table.inner_rows_touching(frontier), lookup)
        frontier = _assign(index, r, w)
    if frontier is None or np.any(index[~table.border] < 0):
        return None
    # 2. The border, most trusted rows first.  A row with both p and q interior is a live
    #    triangle for sure.  A border sample whose two perimeter neighbours are one vertex is
    #    the tip of a welded fold (a cut end); if no trusted row reached it, its triangles
    #    collapsed into a fin that was dropped, so it is not in the mesh: it takes its
    #    neighbour's vertex (the embedder sees the same, see meshwm.embed).
    #    Interior samples are never welded, so a row whose lookup lands on an interior vertex
    #    went through a dropped triangle: it is ignored.
    outer, trust = table.outer, table.trust
    inner_vertex = np.zeros(lookup.n_vertices, dtype=bool)
    inner_vertex[index[~table.border]] = True
    while True:
        r, w = np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        for level in (2, 1, 0):
            r, w = _step(index, outer[trust == level], lookup)
            r, w = r[~inner_vertex[w]], w[~inner_vertex[w]]
            if level < 2:
                pv, nx = index[table.prev[r]], index[table.next[r]]
                fold = (pv >= 0) & (pv == nx)
                r, w = r[~fold], w[~fold]
            if len(r):
                break
        if not len(r):
            break
        if _assign(index, r, w) is None:
            return None
    # Samples still without a vertex are the tips of welded folds (see _fill_fold_tips).
    if np.count_nonzero(index < 0) > 4 * n:
        return None
    # 3. Every mesh face must be exactly one grid triangle (collapsed and fin triangles aside).
    t = index[table.triangles]
    live = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2]) & (t.min(axis=1) >= 0)
    third, face = lookup(t[live, 0], t[live, 1])
    found = face[(third == t[live, 2]) & (face >= 0)]
    if len(found) != n_faces or len(np.unique(found)) != n_faces:
        return None
    return index


def _fill_fold_tips(index: NDArray[np.int64], table: _GridTable) -> None:
    """Give the samples that are not in the mesh the vertex of a perimeter neighbour, in place.

    They are the tips of welded folds (a cut end, or the two corners a path cut joins): their
    triangles closed into fins, which :func:`meshwm.geometry_image.geometry_image_to_mesh`
    drops.  Each takes the vertex of the nearest sample along the perimeter that has one (the
    earlier one in perimeter order on a tie).  The embedder reads its cover through
    :func:`recover_grid` too, so both sides see the same values there.
    """
    for m in np.flatnonzero(index < 0):
        a, b = m, m
        while index[a] < 0 and index[b] < 0:
            a, b = table.prev[a], table.next[b]
        index[m] = index[a] if index[a] >= 0 else index[b]


def _size_from_faces(n_faces: int) -> int:
    n = _MIN_SIZE
    while 2 * (n - 1) ** 2 < n_faces:
        n *= 2
        if n > _MAX_SIZE:
            raise GridError(f"{n_faces} faces is more than a {_MAX_SIZE}-grid has")
    # Collapsed seam triangles are few: a grid of the next size down must not fit either.
    if 2 * (n // 2 - 1) ** 2 >= n_faces:  # pragma: no cover - cannot happen by the loop
        raise GridError("face count fits no grid")
    return n


def recover_grid(vertices: NDArray, faces: NDArray) -> RecoveredGrid:
    """Find which vertex of a meshwm geometry-image mesh is grid sample (i, j).

    Parameters
    ----------
    vertices : (k, 3) float64 ndarray
        Vertex positions (only used to fill ``gim``; the grid is read from ``faces``).
    faces : (m, 3) int64 ndarray
        Triangles of one connected, oriented component, as written by
        :func:`meshwm.geometry_image.geometry_image_to_mesh` and then possibly re-indexed,
        re-welded or transformed.

    Returns
    -------
    RecoveredGrid

    Raises
    ------
    GridError
        No grid verifies: the mesh was not written by meshwm, or its connectivity was changed
        (remeshed, simplified, cut).  A few missing faces are tolerated as long as the walk
        still reaches every sample (and the fiducial is intact).

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.geometry_image import geometry_image_to_mesh
    >>> n = 16
    >>> i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    >>> gim = np.stack([i, j, np.sin(i + j)], axis=-1).astype(float)
    >>> v, f = geometry_image_to_mesh(gim)
    >>> perm = np.random.default_rng(0).permutation(len(v))
    >>> inv = np.argsort(perm)
    >>> grid = recover_grid(v[perm], inv[f])
    >>> grid.n, bool(np.array_equal(grid.gim, gim))
    (16, True)
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise GridError(f"faces must be a non-empty (m, 3) array, got shape {f.shape}")
    n = _size_from_faces(len(f))
    if len(v) > n * n:
        raise GridError(f"{len(v)} vertices is more than an {n} x {n} grid has")
    table = _grid_table(n)
    tried = 0
    for ff in (f, f[:, ::-1]):
        lookup = _Lookup(len(v), ff)
        for seed in _fiducial_candidates(len(v), ff):
            tried += 1
            index = _propagate(n, table, lookup, seed, len(ff))
            if index is not None:
                _fill_fold_tips(index, table)
                index = index.reshape(n, n)
                if len(np.unique(index)) != len(v):
                    continue
                return RecoveredGrid(n, index, v[index], tried)
    raise GridError(
        f"no {n} x {n} geometry-image grid found in the connectivity ({tried} fiducial "
        "candidates tried): the mesh was not written by meshwm or was remeshed"
    )
