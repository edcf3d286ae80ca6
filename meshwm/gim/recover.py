"""Read the geometry-image grid back from the connectivity of a received mesh.

Blind extraction gets a mesh and nothing else: no vertex order (files are re-indexed, an STL
round trip un-indexes and re-welds every vertex), no side file, and maybe not the whole mesh
(a crop removes part of the surface and can split the rest into pieces).  What survives is the
connectivity of what is left, and meshwm writes that connectivity itself
(:func:`meshwm.gim.code.grid_faces`): two triangles per grid cell with alternating
diagonals (a 4-8 mesh: interior samples with i + j even have 8 neighbours, the others 4),
welded along the cut seams, and a *position code*: the code cells (i and j even, off the
border) whose public bit is 1 have their diagonal flipped
(:func:`meshwm.gim.code.flipped_cells`).

:func:`recover_grid` finds which vertex is grid sample (i, j):

1. **Sizes**: N from the face count (the grid has 2 (N-1)^2 triangles, a few fewer where a
   welded cut end collapsed some), then 2N and 4N (a cropped mesh has fewer faces), up to
   2048; or the ``size`` given.  The code decides which N is right: each N has its own bits.
2. **Seeds**: in each connected component large enough to hold a few dozen code cells, the
   flipped code cells found by their valence signature (a diagonal between two valence-5
   vertices whose triangles' third corners have valence 7).  A handful are taken, spread over
   the component.
3. **Local reading**: around each seed, a walk that knows nothing of the code lays out a
   window of 11 x 11 code cells.  Vertices are classed E (valence 7 or 8) or O (4 or 5) when
   their fan is closed; the face with the directed grid edge A -> B of a cell (corners A, B,
   C, D counter-clockwise) has third vertex C if it is of A's class (diagonal A-C), D
   otherwise, and the cell's other face then gives the fourth corner.  Each cell of the
   window then reads as flipped (diagonal between its O corners) or not.
4. **Matching**: the window is looked up in the code of each candidate N, in the 4 rotations
   (faces as given) and the 4 mirror images (winding reversed), at every position: exact
   keys of 5 x 5 code cells (25 bits, a few per window) give the candidate positions, and a
   candidate is kept if at least 40 code cells that agree with the code are connected to
   the seed cell through agreeing code cells, the seed cell being a flipped code cell.  (The
   local walk can cross a welded seam and come back into the grid elsewhere; what it reads
   there is ignored rather than fatal.)  A match gives the seed's absolute position, its
   orientation, N and the winding.
5. **Propagation by oriented triangles**: when two samples p, q of a grid triangle (p, q, r)
   are known as vertices u, v, the one face of the oriented manifold mesh with the directed
   edge u -> v is that triangle, and its third vertex is sample r.  The interior goes first,
   breadth first from the seeds (a cell per step), then the border ring, most trusted
   triangles first, then back into the interior through the border where a piece of it is
   connected to the rest only that way.  Grid triangles on both sides of a welded seam are
   distinct faces with distinct directed edges, so the walk never confuses the two sides.
   On a partial grid the border is read more cautiously (see :func:`_sound`): next to a cut
   end the tip of the fold is no vertex, and only the complete interior could tell a face
   of the other side of the fold from the missing one.
6. **Verification**, per component: no sample reached as two vertices, no interior sample
   sharing its vertex, no face explained twice, and every face between three interior
   samples explained.  A wrong match fails this.  On a complete grid this is the old test:
   every face is exactly one grid triangle and every vertex a sample.
7. **Pieces**: the walk cannot cross a welded seam (it does not know which border samples
   are welded), and a crop can leave parts of the grid connected only across one.  The seed
   cells not read yet are seeded again with N and winding known (a wider window, a key of
   the 16 read code cells nearest the seed compared at every flipped code cell, 24 agreeing
   bits), until nothing large enough is left.  Components read with the same N are merged;
   a sample claimed by two components, or another N, drops the smaller one.  Components and
   pieces too small or without a match are left out.

**Fast path.**  Before all this, :func:`recover_grid` tries the faces in the order meshwm
wrote them (:func:`_read_in_order`), which most pipelines keep: each row of interior cells
is then a contiguous run of faces, found from the run above it, and the border ring is read
from the known interior by the same border phase as step 5, with the same rules.  It reads
only complete grids in the writer's orientation, verifies every face, and otherwise gives
way to the steps above; its reading, hypotheses count included, is the one they make of the
same mesh, so the face order saves time (about 10 ms instead of 125 ms at N = 256) and never
decides a sample.

A welded mesh (close vertices merged, e.g. by MeshLab's ``meshing_merge_close_vertices``)
can have grid samples merged where the remesh crowded them; :func:`drop_irregular` removes the
faces around every vertex no meshwm grid has, so each merge reads as a small hole (the
extraction in :mod:`meshwm.watermark` tries it when the mesh does not read as given or cleaned).

Connectivity fixes the grid completely, including which of the eight symmetries of the square
is meant; the geometry is only used to spread the seeds (and to fill ``gim``), never to decide
a position, so any pose, scale or vertex order reads the same.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse.csgraph import connected_components

from meshwm._validate import check_square_pow2
from meshwm.errors import GridError
from meshwm.gim.code import code_cells, flipped_cells, grid_faces

__all__ = ["GridError", "RecoveredGrid", "drop_irregular", "recover_grid"]

_MIN_SIZE = 16
_MAX_SIZE = 4096
_SEARCH_CAP = 2048  # largest N tried beyond the face-count N when no size is given
_SEARCH_FACTORS = (1, 2, 4)  # N, 2N and 4N of the face count
_WINDOW = 5  # a seed window is 2 * _WINDOW + 1 code cells on a side
_KEY = 5  # side of the exactly matched key block (25 bits)
_KEYS = 6  # key blocks tried per window
_WINDOW_PIECE = 8  # window of the later pieces of a component (N and winding known)
_MIN_BITS_PIECE = 24  # code bits a later piece's window must agree on
_SPARSE = 16  # read code cells nearest the seed compared everywhere for a later piece
_MIN_CELLS_PIECE = 4  # flipped code cells left unread for another piece to be looked for
_MIN_BITS = 40  # code bits a window must agree on (all code cells on grids with fewer)
_SEEDS = 8  # seeds per component
_MAX_WALKS = 8  # full propagations tried per piece
_MAX_PIECES = 6  # pieces read per component (parts connected only across a welded seam)
_DEPTH = 3  # preferred seeds have this many clean rings of vertices around them


class RecoveredGrid(NamedTuple):
    """A grid read from connectivity.

    Attributes
    ----------
    n : int
        The grid size N.
    index : (N, N) int64 ndarray
        Vertex index of each grid sample (welded samples share a vertex); -1 for samples that
        were not read (cropped away, in a piece too small to read, or a border sample at a
        cut, see :func:`recover_grid`).  A sample that is read is always the right one.
    gim : (N, N, 3) float64 ndarray
        The geometry image: ``vertices[index]``, NaN where ``index`` is -1.
    hypotheses : int
        Hypotheses tried, for a Bonferroni correction: seed windows x 8 orientations (4
        rotations, 4 mirror images) x candidate sizes N, summed over components and pieces
        (a full mesh: 8 seeds x 8 x 3 sizes = 192).  A full propagation is run only for the
        few that match the code.  The count does not depend on the vertex or face order (the
        seeds are spread by vertex positions; only exact ties of positions fall back to the
        order).
    coverage : float
        Fraction of the N * N samples that have a vertex (1.0 for a complete grid).
    components : int
        Connected components that were read (merged into ``index``).
    """

    n: int
    index: NDArray[np.int64]
    gim: NDArray[np.float64]
    hypotheses: int
    coverage: float
    components: int


# --------------------------------------------------------------------------------------------
# connectivity


class _Lookup:
    """Directed edge (u, v) -> third vertex of the face that has it, for an oriented mesh."""

    def __init__(self, n_vertices: int, faces: NDArray[np.int64]):
        a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
        keys = np.concatenate([a, b, c]) * n_vertices + np.concatenate([b, c, a])
        third = np.concatenate([c, a, b])
        face = np.tile(np.arange(len(faces)), 3)
        # Stable: fast on the nearly sorted keys of a file as the embedder wrote it.
        order = np.argsort(keys, kind="stable")
        self.keys, self.third, self.face = keys[order], third[order], face[order]
        self.order = order  # position in [a->b of every face, then b->c, then c->a]
        # A directed edge used twice means the mesh is not an oriented manifold there: such
        # edges never answer, so a propagation through them fails verification.
        dup = np.zeros(len(order), dtype=bool)
        dup[1:] = self.keys[1:] == self.keys[:-1]
        dup[:-1] |= dup[1:]
        self.third = np.where(dup, -1, self.third)
        self.n_vertices = n_vertices
        self.reverse = False

    def reversed(self) -> _Lookup:
        """The lookup of the same faces with their winding reversed (corners in reverse order).

        Reversed, the face with the directed edge u -> v is the one that had v -> u, with the
        same third vertex: the same table answers with its arguments swapped.
        """
        other = object.__new__(_Lookup)
        other.__dict__.update(self.__dict__)
        other.reverse = not self.reverse
        return other

    def __call__(
        self, u: NDArray[np.int64], v: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        if self.reverse:
            u, v = v, u
        pos, hit = self.find(u, v)
        return np.where(hit, self.third[pos], -1), np.where(hit, self.face[pos], -1)

    def find(
        self, u: NDArray[np.int64], v: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Position of each directed edge u -> v in the sorted table, and whether it is there
        (as given: ``reverse`` is not applied)."""
        key = u * self.n_vertices + v
        pos = np.minimum(np.searchsorted(self.keys, key), len(self.keys) - 1)
        hit = (self.keys[pos] == key) & (u >= 0) & (v >= 0)
        return pos, hit


class _Fans(NamedTuple):
    """Per directed edge of a lookup's sorted table, and per vertex: what the fans look like."""

    u: NDArray[np.int64]  # first vertex of each directed edge
    v: NDArray[np.int64]  # second vertex
    back_pos: NDArray[np.int64]  # position of the reverse edge v -> u (where ``back``)
    back: NDArray[np.bool_]  # whether v -> u exists
    first: NDArray[np.bool_]  # first occurrence of each directed edge
    valence: NDArray[np.int64]  # faces per vertex
    closed: NDArray[np.bool_]  # every directed edge at the vertex has its reverse
    cls: NDArray[np.int8]  # 0: E (closed, 7 or 8 faces), 1: O (closed, 4 or 5), -1: other


def _fans(lookup: _Lookup, faces: NDArray[np.int64]) -> _Fans:
    n = lookup.n_vertices
    keys = lookup.keys
    u, v = np.divmod(keys, n)
    back_pos, back = lookup.find(v, u)
    closed = np.ones(n, dtype=bool)
    closed[u[~back]] = False
    closed[v[~back]] = False
    first = np.ones(len(keys), dtype=bool)
    first[1:] = keys[1:] != keys[:-1]
    val = np.bincount(faces.ravel(), minlength=n)
    # Class of each vertex: 0 (E, i + j even: valence 8, or 7 at a flipped code cell),
    # 1 (O: 4, or 5), -1 (open fan or another valence: not used by the local reading).
    cls = np.full(n, -1, dtype=np.int8)
    cls[closed & ((val == 7) | (val == 8))] = 0
    cls[closed & ((val == 4) | (val == 5))] = 1
    return _Fans(u, v, back_pos, back, first, val, closed, cls)


class _Mesh:
    """What the reader needs of a mesh: lookups both windings, vertex classes, components."""

    def __init__(self, vertices: NDArray[np.float64], faces: NDArray[np.int64]):
        n = len(vertices)
        self.n_vertices, self.faces, self.vertices = n, faces, vertices
        self.lookup = _Lookup(n, faces)
        self._reversed: _Lookup | None = None
        self._depth: NDArray[np.int64] | None = None
        # A vertex is interior (closed fan) when every directed edge at it has its reverse;
        # only there is the face count the valence of the 4-8 grid.
        fans = _fans(self.lookup, faces)
        self.valence, self.cls = fans.valence, fans.cls
        val = self.valence
        # Plain fans (see _sound): closed, no neighbour twice (a repeated directed edge out of
        # the vertex), and 8 faces (row 0, for samples with i + j even) or 4 (row 1); row 2:
        # vertices of one face (see _border_phase).
        out = np.bincount(fans.u[fans.first], minlength=n)
        simple = fans.closed & (out == val)
        self.plain = np.stack([simple & (val == 8), simple & (val == 4), val == 1])
        graph = sp.csr_matrix(
            (np.ones(2 * len(faces)), (faces[:, :2].ravel(), faces[:, 1:].ravel())),
            shape=(n, n),
        )
        self.graph = graph
        self.n_components, self.label = connected_components(graph, connection="weak")

    def depth(self) -> NDArray[np.int64]:
        # Cached on the instance: a functools.cache on the method would keep every mesh alive.
        if self._depth is None:
            self._depth = _clean_depth(self, _DEPTH + 1)
        return self._depth

    def lookup_for(self, reverse: bool) -> _Lookup:
        if not reverse:
            return self.lookup
        if self._reversed is None:
            self._reversed = self.lookup.reversed()
        return self._reversed


def _signature_seeds(mesh: _Mesh) -> NDArray[np.int64]:
    """(k, 3) vertices (p00, p01, p10) of every flipped code cell found by its valence pattern.

    A flipped cell has triangles (p00, p01, p10) and (p01, p11, p10): p00 and p11 of class E
    with valence 7, p01 and p10 of class O with valence 5.  Each cell is found from both of
    its triangles (the second gives the cell turned by 180 degrees); one is kept.
    """
    f, cls, val = mesh.faces, mesh.cls, mesh.valence
    e7 = (cls == 0) & (val == 7)
    o5 = (cls == 1) & (val == 5)
    found = []
    for k in range(3):
        x, y, z = f[:, k], f[:, (k + 1) % 3], f[:, (k + 2) % 3]
        hit = e7[x] & o5[y] & o5[z]
        x, y, z = x[hit], y[hit], z[hit]
        w, _ = mesh.lookup(z, y)
        keep = (w >= 0) & (x < w)
        keep[keep] &= e7[w[keep]]
        found.append(np.stack([x[keep], y[keep], z[keep]], axis=1))
    return np.concatenate(found)


def _clean_depth(mesh: _Mesh, cap: int) -> NDArray[np.int64]:
    """Edge hops from each vertex to the nearest unclassed one (open fan, odd valence), <= cap."""
    graph = mesh.graph + mesh.graph.T
    reached = mesh.cls < 0
    depth = np.full(mesh.n_vertices, cap, dtype=np.int64)
    depth[reached] = 0
    for d in range(1, cap):
        grown = (graph @ reached.astype(np.float64)) > 0
        new = grown & ~reached
        depth[new] = d
        reached |= grown
    return depth


def _choose_seeds(mesh: _Mesh, cells: NDArray[np.int64], count: int) -> NDArray[np.int64]:
    """Up to ``count`` of the seed cells, away from unclassed vertices and spread out.

    Spread by farthest-point sampling on the vertex positions, starting from the cell nearest
    the centroid of the candidates.  Positions only choose where to look: the grid that is read
    does not depend on them (every correct seed gives the same reading).
    """
    if len(cells) <= count:
        return cells
    good = mesh.depth()[cells].min(axis=1) >= _DEPTH
    if np.count_nonzero(good) >= count:
        cells = cells[good]
    p = mesh.vertices[cells[:, 0]]
    p = np.where(np.isfinite(p), p, 0.0)
    dist = np.linalg.norm(p - p.mean(axis=0), axis=1)
    chosen = [int(np.argmin(dist))]
    dist = np.linalg.norm(p - p[chosen[0]], axis=1)
    for _ in range(count - 1):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(p - p[nxt], axis=1))
    return cells[chosen]


# --------------------------------------------------------------------------------------------
# the local reading of a seed window


class _Window(NamedTuple):
    """Local layout of a seed window: samples (a, b) for a, b in [-2K, 2K + 1]."""

    lo: int
    side: int  # samples per side
    rows: NDArray[np.int64]  # (r, 4) cell corners A, B, C, D counter-clockwise, every rotation
    parity_a: NDArray[np.int64]  # class of A (0 for a + b even)
    corners: NDArray[np.int64]  # (c, 4) q00, q01, q10, q11 of every cell
    cell_ab: NDArray[np.int64]  # (c, 2) local cell (a, b): its corner q00
    cell_parity: NDArray[np.int64]
    code_slot: NDArray[np.int64]  # flat slot of the cell in the (2K + 1)^2 code window, or -1


@functools.lru_cache(maxsize=2)
def _window(k: int) -> _Window:
    lo, hi = -2 * k, 2 * k + 1
    side = hi - lo + 1
    a, b = np.meshgrid(np.arange(lo, hi), np.arange(lo, hi), indexing="ij")
    a, b = a.ravel(), b.ravel()
    q00 = (a - lo) * side + (b - lo)
    q01, q10 = q00 + 1, q00 + side
    q11 = q10 + 1
    cycle = [q00, q01, q11, q10]
    rows = np.concatenate(
        [np.stack([cycle[(r + s) % 4] for s in range(4)], axis=1) for r in range(4)]
    )
    ra, ca = np.divmod(rows[:, 0], side)
    parity_a = (ra + ca + 2 * lo) % 2
    code = (a % 2 == 0) & (b % 2 == 0)
    slot = np.where(code, (a // 2 + k) * (2 * k + 1) + (b // 2 + k), -1)
    return _Window(
        lo,
        side,
        rows,
        parity_a,
        np.stack([q00, q01, q10, q11], axis=1),
        np.stack([a, b], axis=1),
        (a + b) % 2,
        slot,
    )


def _read_windows(mesh: _Mesh, seeds: NDArray[np.int64], k: int) -> NDArray[np.int8]:
    """The diagonal of every cell around each seed cell, read without knowing the code.

    Returns ``(s, cells)`` int8: 1 where the cell's diagonal joins its O corners (a flipped
    code cell, or something else if the cell is off the code lattice), 0 where it joins its E
    corners, -1 unread.  Where the walk contradicts itself (a position reached as two vertices,
    a vertex at two positions: the window wrapped around a cone at a cut end) the positions
    involved are dropped and nothing is read or walked through them.
    """
    win = _window(k)
    s, side = len(seeds), win.side
    size = side * side
    lookup, cls = mesh.lookup, mesh.cls
    idx = np.full((s, size), -1, dtype=np.int64)
    bad = np.zeros((s, size), dtype=bool)
    origin = -win.lo * side - win.lo
    idx[:, origin] = seeds[:, 0]
    idx[:, origin + 1] = seeds[:, 1]
    idx[:, origin + side] = seeds[:, 2]
    a_, b_, c_, d_ = win.rows.T
    flat, flat_bad = idx.ravel(), bad.ravel()
    while True:
        ia, ib = idx[:, a_], idx[:, b_]
        need = (ia >= 0) & (ib >= 0) & ((idx[:, c_] < 0) | (idx[:, d_] < 0))
        kk, rr = np.nonzero(need)
        if not len(kk):
            break
        u, v = ia[kk, rr], ib[kk, rr]
        x, _ = lookup(u, v)
        cx = np.where(x >= 0, cls[np.maximum(x, 0)], -1)
        pa = win.parity_a[rr]
        # x of A's class: triangle (A, B, C), and the cell's other one (A, C, D) has A -> C.
        # Otherwise triangle (A, B, D), and the other one (B, C, D) has D -> B.
        to_c = cx == pa
        sel = to_c | (cx == 1 - pa)
        kk, rr, u, v, x, to_c, pa = kk[sel], rr[sel], u[sel], v[sel], x[sel], to_c[sel], pa[sel]
        y, _ = lookup(np.where(to_c, u, x), np.where(to_c, x, v))
        cy = np.where(y >= 0, cls[np.maximum(y, 0)], -1)
        y_ok = (y >= 0) & ((cy < 0) | (cy == np.where(to_c, 1 - pa, pa)))
        kk = np.concatenate([kk, kk[y_ok]])
        target = np.concatenate(
            [np.where(to_c, c_[rr], d_[rr]), np.where(to_c, d_[rr], c_[rr])[y_ok]]
        )
        x = np.concatenate([x, y[y_ok]])
        slot = kk * size + target
        cur = flat[slot]
        flat_bad[slot[(cur >= 0) & (cur != x)]] = True
        new = (cur < 0) & ~flat_bad[slot]
        slot, x = slot[new], x[new]
        order = np.argsort(slot, kind="stable")
        slot, x = slot[order], x[order]
        same = slot[1:] == slot[:-1]
        flat_bad[slot[1:][same & (x[1:] != x[:-1])]] = True
        first = np.ones(len(slot), dtype=bool)
        first[1:] = ~same
        first &= ~flat_bad[slot]
        if not first.any():
            break
        flat[slot[first]] = x[first]
    # A vertex placed twice: drop both places.
    placed = np.flatnonzero(flat >= 0)
    key = (placed // size) * mesh.n_vertices + flat[placed]
    order = np.argsort(key, kind="stable")
    key, placed = key[order], placed[order]
    twice = np.zeros(len(key), dtype=bool)
    twice[1:] = key[1:] == key[:-1]
    twice[:-1] |= twice[1:]
    flat_bad[placed[twice]] = True
    idx[bad] = -1
    # Read the diagonal of every cell whose four corners are placed.
    q = idx[:, win.corners]  # (s, cells, 4)
    q00, q01, q10, q11 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    t1, _ = lookup(q00, q01)
    t2, _ = lookup(q11, q10)
    main = ((t1 == q11) | (t2 == q00)) & (q11 >= 0) & (q00 >= 0)
    anti = ((t1 == q10) | (t2 == q01)) & (q10 >= 0) & (q01 >= 0)
    flipped = np.where(win.cell_parity == 0, anti, main)
    return np.where(main ^ anti, flipped, -1).astype(np.int8)


# --------------------------------------------------------------------------------------------
# the code, and matching a window against it

# The 8 symmetries of the square acting on (row, column) offsets: 4 rotations, then the 4
# rotations of the transpose (determinant -1: the mesh's winding is reversed).
_ROT = [np.array([[1, 0], [0, 1]]), np.array([[0, -1], [1, 0]])]
_ROT += [_ROT[1] @ _ROT[1], _ROT[1] @ _ROT[1] @ _ROT[1]]
_TRANSFORMS = [*_ROT, *[r @ np.array([[0, 1], [1, 0]]) for r in _ROT]]


class _Code(NamedTuple):
    """The code of one N: per cell, and on the lattice of cells (2I, 2J) with its border."""

    n: int
    cells: NDArray[np.int8]  # (N - 1, N - 1): 1 for a flipped cell
    bits: NDArray[np.int8]  # (H, H), H = N / 2: cell (2I, 2J), 0 on the border ring
    keys: NDArray[np.int64]  # sorted keys of every _KEY x _KEY block of ``bits``
    where: NDArray[np.int64]  # flat top-left (I * H + J) of each key
    min_bits: int


@functools.lru_cache(maxsize=8)
def _code(n: int) -> _Code:
    h = n // 2
    flip = flipped_cells(n)
    cells = np.zeros((n - 1, n - 1), dtype=np.int8)
    cells[flip[:, 0], flip[:, 1]] = 1
    bits = np.zeros((h, h), dtype=np.int8)
    bits[flip[:, 0] // 2, flip[:, 1] // 2] = 1
    # Key of the block with top-left (i, j): bit (i + a, j + b) at position _KEY * a + b.
    span = h - _KEY + 1
    wide = bits.astype(np.int64)
    row = sum(wide[:, b : b + span] << b for b in range(_KEY))
    keys = sum(row[a : a + span] << (_KEY * a) for a in range(_KEY)).ravel()
    order = np.argsort(keys, kind="stable")
    i, j = np.divmod(np.arange(span * span), span)
    where = (i * h + j)[order]
    return _Code(n, cells, bits, keys[order], where, min(_MIN_BITS, len(code_cells(n))))


class _Match(NamedTuple):
    disagree: int
    agree: int
    n: int
    transform: int
    i0: int  # code-lattice cell of the seed cell
    j0: int
    seed: int


def _key_centres(bits: NDArray[np.int8], k: int, count: int) -> list[tuple[int, int]]:
    """Centres of up to ``count`` fully read key blocks: the one nearest the seed, then each
    farthest from those taken (so that a part of the window that is wrong, across a seam, does
    not lose the window)."""
    full = np.lib.stride_tricks.sliding_window_view(bits >= 0, (_KEY, _KEY)).all(axis=(2, 3))
    r, c = np.nonzero(full)
    if not len(r):
        return []
    h = _KEY // 2
    r, c = r + h, c + h
    first = int(np.lexsort((c, r, (r - k) ** 2 + (c - k) ** 2))[0])
    taken = [first]
    gap = np.maximum(abs(r - r[first]), abs(c - c[first]))
    while len(taken) < count:
        nxt = int(np.argmax(gap))
        if gap[nxt] <= h:
            break
        taken.append(nxt)
        gap = np.minimum(gap, np.maximum(abs(r - r[nxt]), abs(c - c[nxt])))
    return [(int(r[t]), int(c[t])) for t in taken]


def _check(
    code: _Code,
    bits: NDArray[np.int8],
    cells: NDArray[np.int64],
    i0: int,
    j0: int,
    k: int,
    min_bits: int,
) -> tuple[int, int] | None:
    """(agreeing bits, disagreeing bits) of a placement if it is accepted, else None.

    ``bits`` is the window on the code lattice, ``cells`` its code cells turned into place
    (offsets from the seed cell).  The bits counted are the code cells that agree with the code
    and are connected to the seed cell through agreeing code cells: the local walk may have
    crossed a welded seam and come back into the grid elsewhere, and what it read there
    disagrees with the code half the time, so it neither counts nor spoils the rest.
    """
    n = code.n
    ci, cj = 2 * (cells[:, 0] + i0), 2 * (cells[:, 1] + j0)
    inside = (ci >= 2) & (cj >= 2) & (ci <= n - 4) & (cj <= n - 4)
    w = 2 * k + 1
    agree = np.zeros((w, w), dtype=bool)
    known = np.flatnonzero(bits.ravel() >= 0)
    same = np.zeros(len(known), dtype=bool)
    same[inside] = code.cells[ci[inside], cj[inside]] == bits.ravel()[known[inside]]
    agree.ravel()[known[same]] = True
    if not agree[k, k]:
        return None
    labels, _ = ndimage.label(agree)
    count = int(np.count_nonzero(labels == labels[k, k]))
    if count < min_bits:
        return None
    return count, int(np.count_nonzero(inside & ~same))


def _match_windows(states: NDArray[np.int8], codes: list[_Code], k: int) -> list[_Match]:
    """Every (N, orientation, position) at which a window agrees with the code.

    Candidates come from exact keys: blocks of _KEY x _KEY code cells read in full, the one
    nearest the seed and others spread over the window.  Each candidate is then checked on the
    whole window (see :func:`_check`).
    """
    win = _window(k)
    w = 2 * k + 1
    code_cell = win.code_slot >= 0
    r, c = np.divmod(np.arange(w * w), w)
    weights = 1 << np.arange(_KEY * _KEY, dtype=np.int64)
    h = _KEY // 2
    out = []
    for s in range(len(states)):
        bits = np.full(w * w, -1, dtype=np.int8)
        bits[win.code_slot[code_cell]] = states[s][code_cell]
        bits = bits.reshape(w, w)
        centres = _key_centres(bits, k, _KEYS)
        known = np.flatnonzero(bits.ravel() >= 0)
        seen = set()
        for t, rot in enumerate(_TRANSFORMS):
            # Code-lattice offsets from the seed cell, turned: the window as it lies in the code.
            turned_cells = np.stack([r[known] - k, c[known] - k], axis=1) @ rot.T
            turned = np.full((w, w), -1, dtype=np.int8)
            turned[turned_cells[:, 0] + k, turned_cells[:, 1] + k] = bits.ravel()[known]
            for centre in centres:
                cr, cc = rot @ np.array([centre[0] - k, centre[1] - k])
                block = turned[cr + k - h : cr + k + h + 1, cc + k - h : cc + k + h + 1]
                key = int((block.ravel().astype(np.int64) * weights).sum())
                for code in codes:
                    hh = code.n // 2
                    lo, hi = np.searchsorted(code.keys, [key, key + 1])
                    for top in code.where[lo:hi].tolist():
                        ti, tj = divmod(top, hh)
                        i0, j0 = ti + h - cr, tj + h - cc
                        if (code.n, t, i0, j0) in seen:
                            continue
                        seen.add((code.n, t, i0, j0))
                        found = _check(code, bits, turned_cells, i0, j0, k, code.min_bits)
                        if found is not None:
                            out.append(_Match(found[1], found[0], code.n, t, i0, j0, s))
    return out


def _match_sparse(
    states: NDArray[np.int8], code: _Code, k: int, transforms: range, min_bits: int
) -> list[_Match]:
    """Like :func:`_match_windows` for one N and winding, without a full key block.

    For the later pieces of a component (N and winding known), often thin strips along a
    seam: the key is the _SPARSE read code cells nearest the seed, whatever their shape, and
    it is compared at every flipped code cell (the seed cell is one) in each rotation.
    """
    win = _window(k)
    w = 2 * k + 1
    code_cell = win.code_slot >= 0
    r, c = np.divmod(np.arange(w * w), w)
    flipped = np.argwhere(code.bits[1:-1, 1:-1] == 1) + 1  # code-lattice cells of the code
    out = []
    for s in range(len(states)):
        bits = np.full(w * w, -1, dtype=np.int8)
        bits[win.code_slot[code_cell]] = states[s][code_cell]
        known = np.flatnonzero(bits >= 0)
        off = np.stack([r[known] - k, c[known] - k], axis=1)
        if len(known) < min_bits:
            continue
        near = np.argsort((off**2).sum(axis=1), kind="stable")[1 : _SPARSE + 1]
        bits = bits.reshape(w, w)
        for t in transforms:
            rot = _TRANSFORMS[t]
            turned_cells = off @ rot.T
            key = turned_cells[near]
            ii = flipped[:, :1] + key[:, 0]
            jj = flipped[:, 1:] + key[:, 1]
            h = code.n // 2
            inside = (ii >= 0) & (ii < h) & (jj >= 0) & (jj < h)
            got = code.bits[np.clip(ii, 0, h - 1), np.clip(jj, 0, h - 1)]
            hit = np.all(inside & (got == bits.ravel()[known[near]]), axis=1)
            for i0, j0 in flipped[hit].tolist():
                found = _check(code, bits, turned_cells, i0, j0, k, min_bits)
                if found is not None:
                    out.append(_Match(found[1], found[0], code.n, t, i0, j0, s))
    return out


def _seed_samples(m: _Match) -> NDArray[np.int64]:
    """Grid samples (flat) of the seed cell's local (0, 0), (0, 1), (1, 0) under a match."""
    rot = _TRANSFORMS[m.transform]
    local = np.array([[0, 0], [0, 1], [1, 0]])
    # Cell centres map to cell centres: local (a, b) -> rot (a - 1/2, b - 1/2) + centre.
    shift = (1 - rot.sum(axis=1)) // 2
    ij = local @ rot.T + shift + 2 * np.array([m.i0, m.j0])
    return ij[:, 0] * m.n + ij[:, 1]


# --------------------------------------------------------------------------------------------
# the pattern-driven walk


class _GridTable:
    """The grid triangles and the rows of the walk: (p, q, r) corner rotations of triangles,
    (A, B, C, D) rotations of cells.  Interior rows are computed from the positions they
    touch (the grid is regular), so the table stays small for large N."""

    def __init__(self, n: int):
        t = grid_faces(n)
        i, j = np.divmod(np.arange(n * n), n)
        border = (i == 0) | (j == 0) | (i == n - 1) | (j == n - 1)
        self.n, self.triangles, self.border = n, t, border
        # Per cell: whether its diagonal is p00-p11 (first triangle (p00, p01, p11)).
        q00 = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
        self.main = t[0::2, 2] == q00 + n + 1
        # Border rows (r on the border), with their trust: how many of p, q are interior;
        # re-entry rows: r interior, p or q on the border (a piece reached across a seam).
        # Both come from the triangles of the cells along the border only.
        m = n - 1
        edge = np.arange(m)
        ring = np.unique(np.concatenate([edge, (m - 1) * m + edge, edge * m, edge * m + m - 1]))
        tri = t[np.concatenate([2 * ring, 2 * ring + 1])]
        rows = np.concatenate([tri, tri[:, [1, 2, 0]], tri[:, [2, 0, 1]]])
        outer = rows[border[rows[:, 2]]]
        self.outer = outer
        self.trust = (~border[outer[:, 0]]).astype(int) + (~border[outer[:, 1]]).astype(int)
        self.mixed = rows[~border[rows[:, 2]] & (border[rows[:, 0]] | border[rows[:, 1]])]
        # Each border sample's two neighbours along the perimeter of the square.
        loop = np.concatenate(
            [
                np.arange(n),  # row 0, left to right
                np.arange(1, n) * n + n - 1,  # column N-1, downwards
                (n - 1) * n + np.arange(n - 2, -1, -1),  # row N-1, right to left
                np.arange(n - 2, 0, -1) * n,  # column 0, upwards
            ]
        )
        self.prev = np.full(n * n, -1, dtype=np.int64)
        self.next = np.full(n * n, -1, dtype=np.int64)
        self.prev[loop] = np.roll(loop, 1)
        self.next[loop] = np.roll(loop, -1)
        # Every cell in each of its 4 rotations, for the row sweep (see :func:`_sweep`):
        # ``spin[r]`` is (N-1, N-1, 4) corners A, B, C, D, ``spin_ac[r]`` the A-C diagonal.
        ci, cj = np.divmod(np.arange((n - 1) ** 2), n - 1)
        c00 = ci * n + cj
        cycle = [c00, c00 + 1, c00 + n + 1, c00 + n]
        self.spin = np.stack(
            [np.stack([cycle[(r + k) % 4] for k in range(4)], axis=-1) for r in range(4)]
        ).reshape(4, n - 1, n - 1, 4)
        main = self.main.reshape(n - 1, n - 1)
        self.spin_ac = np.stack([main, ~main, main, ~main])

    def _cells_around(self, positions: NDArray[np.int64]) -> tuple[NDArray, NDArray]:
        """The (up to) 4 cells with a corner at each position: (k, 4) cell index, valid mask."""
        n = self.n
        i, j = np.divmod(positions, n)
        ci = i[:, None] + np.array([-1, -1, 0, 0])
        cj = j[:, None] + np.array([-1, 0, -1, 0])
        ok = (ci >= 0) & (ci < n - 1) & (cj >= 0) & (cj < n - 1)
        return np.where(ok, ci * (n - 1) + cj, 0), ok

    def inner_rows_touching(self, positions: NDArray[np.int64]) -> NDArray[np.int64]:
        """Rows (p, q, r) of the triangles around ``positions`` with p or q one of them and
        p, q, r off the border.  Border cells are the only ones a weld can collapse, so the
        interior walk meets nothing but live triangles."""
        cell, ok = self._cells_around(positions)
        faces = np.stack([2 * cell, 2 * cell + 1], axis=2).reshape(len(positions), 8)
        tri = self.triangles[faces]  # (k, 8, 3)
        rows = np.concatenate([tri, tri[..., [1, 2, 0]], tri[..., [2, 0, 1]]], axis=1)
        valid = np.tile(np.repeat(ok, 2, axis=1), 3)
        own = positions[:, None]
        keep = valid & ((rows[..., 0] == own) | (rows[..., 1] == own))
        keep &= ~self.border[rows].any(axis=2)
        return rows[keep]

    def cell_rows_touching(
        self, positions: NDArray[np.int64]
    ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Rows (A, B, C, D) of the cells around ``positions`` (counter-clockwise corners, every
        rotation) with A or B one of them and all four corners off the border, and whether the
        cell's diagonal is A-C.  Knowing A and B gives both other corners at once (two
        lookups), so the walk advances a whole cell per step."""
        n = self.n
        cell, ok = self._cells_around(positions)
        ci, cj = np.divmod(cell, n - 1)
        ok &= (ci >= 1) & (ci <= n - 3) & (cj >= 1) & (cj <= n - 3)
        q00 = ci * n + cj
        cycle = [q00, q00 + 1, q00 + n + 1, q00 + n]
        rows = np.stack(
            [np.stack([cycle[(r + k) % 4] for k in range(4)], axis=-1) for r in range(4)], axis=2
        )  # (k, 4 cells, 4 rotations, 4 corners)
        main = self.main[cell]
        ac = np.stack([main, ~main, main, ~main], axis=2)
        own = positions[:, None, None]
        keep = ok[..., None] & ((rows[..., 0] == own) | (rows[..., 1] == own))
        return rows[keep], ac[keep]


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


def _cell_step(
    index: NDArray[np.int64], rows: NDArray[np.int64], ac: NDArray[np.bool_], lookup: _Lookup
):
    """The two other corners of the cells whose A, B are known and C or D is not.

    With the diagonal A-C the face with A -> B is (A, B, C) and the other one (A, C, D) has
    A -> C; with B-D they are (A, B, D) and (B, C, D), which has D -> B.
    """
    a, b = index[rows[:, 0]], index[rows[:, 1]]
    sel = (a >= 0) & (b >= 0) & ((index[rows[:, 2]] < 0) | (index[rows[:, 3]] < 0))
    rows, ac, a, b = rows[sel], ac[sel], a[sel], b[sel]
    x, _ = lookup(a, b)
    y, _ = lookup(np.where(ac, a, x), np.where(ac, x, b))
    first = np.where(ac, rows[:, 2], rows[:, 3])
    second = np.where(ac, rows[:, 3], rows[:, 2])
    return (
        np.concatenate([first[x >= 0], second[y >= 0]]),
        np.concatenate([x[x >= 0], y[y >= 0]]),
    )


def _sweep(
    index: NDArray[np.int64], table: _GridTable, lookup: _Lookup, seed: NDArray[np.int64]
) -> bool:
    """Fill the interior from a seed cell by whole rows of cells, in place; False on a
    contradiction.

    The same propagation as the breadth-first walk of :func:`_interior` (a cell whose A, B are
    known gives C and D), in an order that needs a few hundred small array operations instead
    of a breadth-first front per step: along the seed cell's row of cells in both directions,
    then row by row down and up, every row at once.  What it cannot reach (a partial grid) is
    left to :func:`_interior`, which continues from the edge of what is known; the closure of
    the propagation does not depend on its order, and a sample computed twice (from the two
    cells that share it) must agree.
    """
    n = table.n
    lo, hi = 1, n - 3  # cells whose four corners are off the border
    i0 = int(np.min(seed // n))
    j0 = int(np.min(seed % n))
    if not (lo <= i0 <= hi and lo <= j0 <= hi):
        return True

    def step(rows: NDArray[np.int64], ac: NDArray[np.bool_]) -> bool:
        # As _cell_step + _assign, leaner: C and D of every cell whose A, B are known (known
        # ones are recomputed and must agree), written at once, then read back: two cells
        # that disagree on a shared corner leave one of them unequal.
        a, b = index[rows[:, 0]], index[rows[:, 1]]
        x, _ = lookup(a, b)
        y, _ = lookup(np.where(ac, a, x), np.where(ac, x, b))
        r = np.concatenate([rows[:, 2], rows[:, 3]])
        w = np.concatenate([np.where(ac, x, y), np.where(ac, y, x)])
        r, w = r[w >= 0], w[w >= 0]
        old = index[r]
        if np.any((old >= 0) & (old != w)):
            return False
        index[r] = w
        return bool(np.array_equal(index[r], w))

    spin, spin_ac = table.spin, table.spin_ac
    if not step(spin[:, i0, j0], spin_ac[:, i0, j0]):
        return False
    # Along the seed's row of cells, both ways at once: rotation 3 has A, B on a cell's left
    # edge (going right), rotation 1 on its right edge (going left).
    for d in range(1, max(hi - j0, j0 - lo) + 1):
        turn = [t for t, j in ((3, j0 + d), (1, j0 - d)) if lo <= j <= hi]
        js = [j0 + d if t == 3 else j0 - d for t in turn]
        if not step(spin[turn, i0, js], spin_ac[turn, i0, js]):
            return False
    # Then whole rows, up and down at once: rotation 0 has A, B on the top edge (going down),
    # rotation 2 on the bottom edge (going up).
    width = hi - lo + 1
    cols = np.arange(lo, hi + 1)
    for d in range(1, max(hi - i0, i0 - lo) + 1):
        turn = [t for t, i in ((0, i0 + d), (2, i0 - d)) if lo <= i <= hi]
        ts = np.repeat(turn, width)
        is_ = np.repeat([i0 + d if t == 0 else i0 - d for t in turn], width)
        js = np.tile(cols, len(turn))
        if not step(spin[ts, is_, js], spin_ac[ts, is_, js]):
            return False
    return True


def _edge_of_known(index: NDArray[np.int64], table: _GridTable) -> NDArray[np.int64]:
    """Known interior samples next to an unknown interior one (8-neighbourhood)."""
    n = table.n
    inner = ~table.border
    unknown = np.pad((inner & (index < 0)).reshape(n, n), 1)
    near = np.zeros((n, n), dtype=bool)
    for di in (0, 1, 2):
        for dj in (0, 1, 2):
            near |= unknown[di : di + n, dj : dj + n]
    return np.flatnonzero(inner & (index >= 0) & near.ravel())


def _interior(
    index: NDArray[np.int64],
    table: _GridTable,
    lookup: _Lookup,
    frontier: NDArray[np.int64] | None,
) -> bool:
    """Reach the interior breadth first from ``frontier``, in place; False on a contradiction.

    Cell by cell first; then triangle by triangle from every interior sample known, for what a
    piece with missing faces leaves reachable only through a single triangle.
    """
    while frontier is not None and len(frontier):
        r, w = _cell_step(index, *table.cell_rows_touching(frontier), lookup)
        frontier = _assign(index, r, w)
    if frontier is None:
        return False
    inner = ~table.border
    if np.all(index[inner] >= 0):
        return True
    # Only known samples next to an unknown interior one can reach anything new.
    frontier = _edge_of_known(index, table)
    while frontier is not None and len(frontier):
        r, w = _step(index, table.inner_rows_touching(frontier), lookup)
        frontier = _assign(index, r, w)
    return frontier is not None


def _sound(
    index: NDArray[np.int64], table: _GridTable, rows: NDArray[np.int64], plain: NDArray
) -> NDArray[np.int64]:
    """The rows with one of p, q on the border (B) and the other (I) not, that cannot meet
    another face than their own triangle.

    They could only if I had two grid neighbours on the border welded together, B and B': the
    directed edge I-B is then also I-B'.  Welded neighbours of one sample come from a fold of
    the border around the sample between them, the tip, which has i + j odd, so its two
    triangles closed into a fin that was dropped: the tip is no vertex.  Hence a row is sound
    if I has i + j odd (its only border neighbour is B), or the border sample across from I is
    known (so it is no tip), or I's two neighbours along the border are known (the other face
    a fold would give has one of them as third vertex, which the caller refuses as a known
    interior vertex), or I's vertex is plain (``plain[parity, vertex]``: a closed fan without
    a repeated neighbour and with the 8 (i + j even) or 4 (odd) faces every sample next to the
    border has in a meshwm grid, which a sample next to a tip has not).  Next to a corner of
    the square (several border neighbours) only the last test is used.
    """
    bp, bq = table.border[rows[:, 0]], table.border[rows[:, 1]]
    rows = rows[bp != bq]
    inner = np.where(bp[bp != bq], rows[:, 1], rows[:, 0])
    n = table.n
    i, j = np.divmod(inner, n)
    parity = (i + j) % 2
    vertex = index[inner]
    ok = (vertex >= 0) & plain[parity, np.maximum(vertex, 0)]
    # The border sample across from I, and I's two neighbours along the border.
    di = np.where(i == 1, -1, np.where(i == n - 2, 1, 0))
    dj = np.where(j == 1, -1, np.where(j == n - 2, 1, 0))
    corner = (di != 0) & (dj != 0)
    across = (i + di) * n + j + dj
    beside = (index[(i + dj) * n + j + di] >= 0) & (index[(i - dj) * n + j - di] >= 0)
    free = ~corner & ((parity == 1) | (index[across] >= 0) | beside)
    return rows[ok | ((vertex >= 0) & free)]


def _border_phase(
    index: NDArray[np.int64],
    table: _GridTable,
    lookup: _Lookup,
    levels: tuple[int, ...],
    plain: NDArray[np.bool_] | None = None,
) -> bool:
    """Reach the border ring, most trusted rows first; False on a contradiction.

    A row with both p and q interior is a live triangle for sure.  A border sample whose two
    perimeter neighbours are one vertex is the tip of a welded fold (a cut end): its triangles
    closed into a fin that was dropped, so it is not in the mesh and only an untrusted row
    could reach it (through another face): such rows are ignored.  Interior samples are never
    welded, so a row whose lookup lands on an interior vertex went through a dropped triangle:
    it is ignored too.

    Those two guards need the whole interior known.  On a partial grid (``plain`` given: see
    :class:`_Mesh`) the rows with one of p, q interior are limited to the ones :func:`_sound`
    keeps, and rows with p and q both on the border (the corner cells of the square) may only
    land on a vertex whose one face is the one found (a corner sample of an open grid).
    """
    outer, trust = table.outer, table.trust
    inner_vertex = np.zeros(lookup.n_vertices, dtype=bool)
    inner = index[~table.border]
    inner_vertex[inner[inner >= 0]] = True
    while True:
        r, w = np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
        for level in levels:
            rows = outer[trust == level]
            if plain is not None and level == 1:
                rows = _sound(index, table, rows, plain)
            r, w = _step(index, rows, lookup)
            keep = ~inner_vertex[w]
            if plain is not None and level == 0:
                keep &= plain[2, w]  # a corner of the square: a vertex with that face only
            r, w = r[keep], w[keep]
            if level < 2:
                pv, nx = index[table.prev[r]], index[table.next[r]]
                fold = (pv >= 0) & (pv == nx)
                r, w = r[~fold], w[~fold]
            if len(r):
                break
        if not len(r):
            return True
        if _assign(index, r, w) is None:
            return False


def _walk(
    table: _GridTable,
    lookup: _Lookup,
    samples: NDArray[np.int64],
    seed: NDArray[np.int64],
    base: NDArray[np.int64] | None = None,
    plain: NDArray[np.bool_] | None = None,
) -> NDArray[np.int64] | None:
    """The sample -> vertex map reached from a seed (-1 where not reached); None on a
    contradiction.

    Interior first (breadth first), then the border, then back into the interior through the
    border (re-entry rows: r interior, p or q on the border) wherever a piece of the interior
    is connected to the rest only that way; repeated until nothing new.  On a complete mesh
    the first interior pass reaches every interior sample, the border is read exactly as it
    always was, and re-entry finds nothing.  If the first pass leaves interior samples
    unknown (a partial grid), untrusted rows are limited to the ones :func:`_sound` keeps
    (``plain``, see there).
    """
    n = table.n
    index = np.full(n * n, -1, dtype=np.int64) if base is None else base.copy()
    frontier = _assign(index, samples, seed)
    if frontier is None or np.any(table.border[samples]):
        return None
    if base is None:
        # The fast order first; the breadth-first walk goes on from the edge of what it left.
        if not _sweep(index, table, lookup, samples[:3]):
            return None
        frontier = _edge_of_known(index, table)
    strict: NDArray[np.bool_] | None = None
    while True:
        if not _interior(index, table, lookup, frontier):
            return None
        if strict is None:
            partial = base is not None or np.any(index[~table.border] < 0)
            strict = plain if partial and plain is not None else np.zeros(0, dtype=bool)
        check = strict if len(strict) else None
        progressed = False
        for levels in ((2,), (2, 1, 0)):
            if not _border_phase(index, table, lookup, levels, check):
                return None
            rows = table.mixed if check is None else _sound(index, table, table.mixed, check)
            r, w = _step(index, rows, lookup)
            frontier = _assign(index, r, w)
            if frontier is None:
                return None
            if len(frontier):
                progressed = True
                break
        if not progressed:
            return index


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
    boxed = interior[faces].all(axis=1)
    boxed[explained] = False
    return not boxed.any()


def _fill_fold_tips(index: NDArray[np.int64], table: _GridTable) -> None:
    """Give the samples that are not in the mesh the vertex of a perimeter neighbour, in place.

    Only for a complete grid (see :func:`recover_grid`): there the missing samples are the tips
    of welded folds (a cut end, or the two corners a path cut joins): their triangles closed
    into fins, which :func:`meshwm.gim.to_mesh.geometry_image_to_mesh` drops.  Each takes the
    vertex of the nearest sample along the perimeter that has one (the earlier one in perimeter
    order on a tie).  The embedder reads its cover through :func:`recover_grid` too, so both
    sides see the same values there.
    """
    for m in np.flatnonzero(index < 0):
        a, b = m, m
        while index[a] < 0 and index[b] < 0:
            a, b = table.prev[a], table.next[b]
        index[m] = index[a] if index[a] >= 0 else index[b]


class _Reading(NamedTuple):
    n: int
    index: NDArray[np.int64] | None
    faces: int  # faces explained
    hypotheses: int
    seeds: int


def _walk_matches(
    mesh: _Mesh,
    seeds: NDArray[np.int64],
    matches: list[_Match],
    base: NDArray[np.int64] | None,
    min_faces: int,
) -> tuple[NDArray[np.int64], NDArray[np.int64], int, bool] | None:
    """The first match whose walk verifies: (index, explained faces, N, reversed), or None.

    Clean matches nearest the grid centre are tried first, and before them all the clean
    matches that agree with the best one on N and winding together (many sources make the walk
    short).  A walk verifies if it meets no contradiction (with itself or with ``base``, the
    pieces of the component read before), explains no face twice, leaves no face between
    three interior samples unexplained, and explains at least ``min_faces`` new faces.
    """
    done = 0 if base is None else None
    mine = sorted(
        matches,
        key=lambda m: (m.disagree > 0, abs(2 * m.i0 - m.n // 2) + abs(2 * m.j0 - m.n // 2), m.n),
    )
    attempts = [[m] for m in mine]
    if mine:
        best = mine[0]
        group = [
            m
            for m in mine
            if m.disagree == 0 and m.n == best.n and (m.transform >= 4) == (best.transform >= 4)
        ]
        if len(group) > 1:
            attempts.insert(0, group)
    tried: list[tuple[int, bool, NDArray[np.int64]]] = []
    for group in attempts:
        m = group[0]
        samples = np.concatenate([_seed_samples(g) for g in group])
        start = np.concatenate([seeds[g.seed] for g in group])
        reverse = m.transform >= 4
        if any(
            tn == m.n and tr == reverse and np.array_equal(ti[samples], start)
            for tn, tr, ti in tried
        ):
            continue  # the same reading from another seed
        if len(tried) >= _MAX_WALKS:
            break
        table = _grid_table(m.n)
        lookup = mesh.lookup_for(reverse)
        index = _walk(table, lookup, samples, start, base, mesh.plain)
        if index is None:
            continue
        tried.append((m.n, reverse, index))
        found = _explained(index, table, lookup)
        if found is None or not _consistent(index, table, mesh.faces, found):
            continue
        if done is None:
            done = len(_explained(base, table, lookup))
        if len(found) - done >= min_faces:
            return index, found, m.n, reverse
    return None


def _read_component(
    mesh: _Mesh,
    cells: NDArray[np.int64],
    seeds: NDArray[np.int64],
    codes: list[_Code],
    min_faces: int,
) -> _Reading:
    """Read one connected component, piece by piece.

    A crop can leave parts of the grid that are connected to each other only across a welded
    seam, which the walk cannot cross (it does not know which border samples are welded).
    After the first piece, the seed cells not yet read are seeded again (same N and winding),
    until no piece of at least ``min_faces`` faces is left to read.
    """
    index, found = None, np.zeros(0, dtype=np.int64)
    n, reverse = 0, False
    hypotheses = seeded = 0
    for _ in range(_MAX_PIECES):
        if index is not None:
            assigned = np.zeros(mesh.n_vertices, dtype=bool)
            assigned[index[index >= 0]] = True
            cells = cells[~assigned[cells].any(axis=1)]
            if len(cells) < _MIN_CELLS_PIECE:
                break
            seeds = _choose_seeds(mesh, cells, _SEEDS)
            codes = [code for code in codes if code.n == n]
        hypotheses += len(seeds) * len(_TRANSFORMS) * len(codes)
        seeded += len(seeds)
        if index is None:
            states = _read_windows(mesh, seeds, _WINDOW)
            matches = _match_windows(states, codes, _WINDOW)
            piece = _walk_matches(mesh, seeds, matches, None, min_faces)
        else:
            # A later piece: N and winding known, so fewer bits tell where it is; a wider
            # window collects them along a strip.
            states = _read_windows(mesh, seeds, _WINDOW_PIECE)
            turns = range(4, 8) if reverse else range(4)
            matches = _match_sparse(states, codes[0], _WINDOW_PIECE, turns, _MIN_BITS_PIECE)
            piece = _walk_matches(mesh, seeds, matches, index, 8 * _MIN_BITS_PIECE)
        if piece is None:
            break
        index, found, n, reverse = piece
    return _Reading(n, index, len(found), hypotheses, seeded)


def _read_components(mesh: _Mesh, codes: list[_Code], min_faces: int) -> list[tuple[int, _Reading]]:
    """Each component with ``min_faces`` faces and a seed cell, read on its own, largest first
    (ties: more vertices, then more seed cells: order-free keys)."""
    comp_faces = np.bincount(mesh.label[mesh.faces[:, 0]], minlength=mesh.n_components)
    comp_vertices = np.bincount(mesh.label, minlength=mesh.n_components)
    cells = _signature_seeds(mesh)
    cell_label = mesh.label[cells[:, 0]]
    seeds_in = np.bincount(cell_label, minlength=mesh.n_components)
    comps = [
        c
        for c in np.lexsort((-seeds_in, -comp_vertices, -comp_faces)).tolist()
        if comp_faces[c] >= min_faces and seeds_in[c]
    ]
    out = []
    for c in comps:
        mine = cells[cell_label == c]
        first = _choose_seeds(mesh, mine, _SEEDS)
        out.append((c, _read_component(mesh, mine, first, codes, min_faces)))
    return out


# --------------------------------------------------------------------------------------------
# welded meshes


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


# --------------------------------------------------------------------------------------------
# sizes


def _size_from_faces(n_faces: int) -> int:
    n = _MIN_SIZE
    while 2 * (n - 1) ** 2 < n_faces:
        n *= 2
        if n > _MAX_SIZE:
            raise GridError(f"{n_faces} faces is more than a {_MAX_SIZE}-grid has")
    return n


def _candidate_sizes(n_faces: int, n_vertices: int, size: int | None) -> list[int]:
    """N to try: ``size``, or the N the face count fits and its 2x and 4x (capped)."""
    if size is not None:
        n = check_square_pow2(size, name="size", low=_MIN_SIZE, high=_MAX_SIZE)
        if 2 * (n - 1) ** 2 < n_faces:
            raise GridError(f"{n_faces} faces is more than a {n} x {n} grid has")
        return [n]
    n0 = _size_from_faces(n_faces)
    sizes = [n0 * f for f in _SEARCH_FACTORS if n0 * f <= max(n0, _SEARCH_CAP)]
    return [n for n in sizes if n * n >= n_vertices]


# --------------------------------------------------------------------------------------------
# fast path: faces in the order meshwm wrote them


class _RunTable(NamedTuple):
    """The interior cells of an N-grid as :func:`grid_faces` lists them: rows of cells 1..N-3,
    columns 1..N-3, each row a contiguous run of faces; and the border cells' faces."""

    runs: NDArray[np.int64]  # (N-3, 2(N-3), 3) the interior triangles, a row of cells per run
    types: NDArray[np.int8]  # (N-3, N-3) per interior cell: 1 diagonal p00-p11, 2 p01-p10
    border_faces: NDArray[np.int64]  # (k, 3) the triangles of the border cells


@functools.lru_cache(maxsize=4)
def _run_table(n: int) -> _RunTable:
    table = _grid_table(n)
    w, seg = 2 * (n - 1), 2 * (n - 3)
    first = np.arange(1, n - 2) * w + 2
    pos = first[:, None] + np.arange(seg)
    in_run = np.zeros(len(table.triangles), dtype=bool)
    in_run[pos] = True
    types = np.where(table.main, 1, 2).astype(np.int8).reshape(n - 1, n - 1)[1:-1, 1:-1]
    out = _RunTable(table.triangles[pos], np.ascontiguousarray(types), table.triangles[~in_run])
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=8)
def _n_flipped(n: int) -> int:
    return len(flipped_cells(n))


def _pair_types(f: NDArray[np.int64]) -> NDArray[np.int8]:
    """For each face k, the cell type of faces (k, k+1) if they are one grid cell.

    1: a cell with diagonal p00-p11, faces (p00, p01, p11), (p00, p11, p10); 2: diagonal
    p01-p10, faces (p00, p01, p10), (p01, p11, p10); 0: neither.  Only vertex equalities are
    used, so any vertex numbering gives the same types.
    """
    a, b = f[:-1], f[1:]
    out = np.zeros(len(f), dtype=np.int8)
    out[:-1][(a[:, 0] == b[:, 0]) & (a[:, 2] == b[:, 1])] = 1
    out[:-1][(a[:, 1] == b[:, 0]) & (a[:, 2] == b[:, 2])] = 2
    return out


def _run_starts(f: NDArray[np.int64], n: int, runs: _RunTable) -> NDArray[np.int64] | None:
    """Where each row of interior cells starts in ``f``, if the faces are in grid order.

    Between two runs lie the border cells that end one row of cells and start the next: four
    faces, fewer where a weld collapsed some.  Row r's run starts with cell (r, 1), whose first
    two corners are samples (r, 1) and (r, 2): corners of cell (r-1, 1) at the start of the
    run above.  So each run follows from the one before, and only the first is searched: at
    every offset the faces missing before it allow, by the cell types of its faces.  A run
    shifted by two cells can chain as well (rows of cells repeat with period two where they
    hold no code cell); the cell types of every run, position code included, rule it out.
    """
    m = len(f)
    w, seg = 2 * (n - 1), 2 * (n - 3)
    big_m = 2 * (n - 1) ** 2
    ftype = _pair_types(f)
    low = max(0, w + 2 - (big_m - m)) if m <= big_m else 0
    cand = np.arange(w + 2, low - 1, -1)
    cand = cand[cand + (n - 3) * w <= m]
    if not len(cand):
        return None
    cells = 2 * np.arange(n - 3)
    cand = cand[np.all(ftype[cand[:, None] + cells] == runs.types[0], axis=1)]
    c0, c1, c2 = (memoryview(np.ascontiguousarray(f[:, c])) for c in range(3))
    main = (runs.types[:, 0] == 1).tolist()
    for s1 in cand.tolist():
        starts = [s1]
        for r in range(1, n - 3):
            prev = starts[-1]
            # Cell (r, 1) of the run above is faces prev, prev + 1 (run rows count from 0):
            # the next run's first corners are its p10 and p11.
            v1 = c2[prev + 1]
            v2 = c2[prev] if main[r - 1] else c1[prev + 1]
            for k in range(prev + seg, min(prev + seg + 4, m - seg) + 1):
                if c0[k] == v1 and c1[k] == v2:
                    starts.append(k)
                    break
            else:
                break
        if len(starts) == n - 3:
            got = np.array(starts)
            if np.all(ftype[got[:, None] + cells] == runs.types):
                return got
    return None


def _read_in_order(
    v: NDArray[np.float64], f: NDArray[np.int64], n: int, size: int | None
) -> RecoveredGrid | None:
    """A complete grid read with the help of its face order, or None (then the order-free way).

    Every file meshwm writes lists the grid's faces in :func:`grid_faces` order (less the
    triangles a welded seam collapsed, all in border cells), then the components passed
    through, and most pipelines keep that order: format conversions, transforms, merging
    duplicate vertices (the vertex order does not matter here).  Then the interior cells
    are contiguous runs of faces, one per row of cells (:func:`_run_starts`), and give every
    interior sample.  The border ring is read exactly as the order-free reader reads it on a
    complete grid, by :func:`_border_phase` from the known interior, with a lookup of the
    faces between the runs (every triangle of a border cell is there, and no query can be
    answered by a face of a run: those have interior vertices only, and the directed edges
    between interior samples that border triangles have are not theirs).

    Everything is verified: each run is the interior triangles under one vertex per sample;
    every face between the runs is one border triangle of the reading, each explained once;
    interior samples have vertices of their own; the faces after the grid (other
    components) share no vertex with it, none holds a seed of another grid, and none is
    larger.  A mesh that passes is a complete grid in the writer's orientation, and the
    reading is the one the order-free reader makes of it, hypotheses count included (a test
    compares them on every development mesh): the face order only saves time, it never
    decides a sample.  Any doubt returns None.
    """
    m = len(f)
    if n < _MIN_SIZE or _n_flipped(n) < _SEEDS or m < 2 * (n - 1) ** 2 - 8 * n:
        return None
    runs = _run_table(n)
    starts = _run_starts(f, n, runs)
    if starts is None:
        return None
    seg = 2 * (n - 3)
    ran = np.take(f, starts[:, None] + np.arange(seg), axis=0)  # (n-3, seg, 3)
    index = np.full((n, n), -1, dtype=np.int64)
    index[1:-2, 1:-2] = ran[:, 0::2, 0]  # p00 of cells (r, c), 1 <= r, c <= n-3
    index[1:-2, -2] = ran[:, -2, 1]  # p01 of cells (r, n-3)
    index[-2, 1:-2] = ran[-1, 1::2, 2]  # p10 of cells (n-3, c)
    index[-2, -2] = ran[-1, -1, 1]  # p11 of cell (n-3, n-3)
    index = index.ravel()
    if not np.array_equal(index[runs.runs], ran):
        return None
    # The faces between the runs, and after the last one (to the end: other components are
    # left over below).
    between = np.ones(m, dtype=bool)
    between[(starts[:, None] + np.arange(seg)).ravel()] = False
    rest = np.flatnonzero(between)
    table = _grid_table(n)
    lookup = _Lookup(len(v), f[rest])
    for levels in ((2,), (2, 1, 0)):  # as :func:`_walk` on a complete interior
        if not _border_phase(index, table, lookup, levels):
            return None
    # Every face between the runs one border triangle, each once, up to where the grid ends.
    found = _explained(index, table, lookup, runs.border_faces)
    if found is None:
        return None
    hit = np.bincount(found, minlength=len(rest))
    end = int(rest[np.flatnonzero(hit)[-1]]) + 1 if np.any(hit) else int(starts[-1]) + seg
    if end < int(starts[-1]) + seg or not np.all(hit[rest < end]):
        return None
    have = index >= 0
    uses = np.bincount(index[have], minlength=len(v))
    if np.any(uses[index[~table.border]] != 1) or np.count_nonzero(~have) > 4 * n:
        return None
    grid_vertices = int(np.count_nonzero(uses))
    sizes = _candidate_sizes(end, grid_vertices, size)
    if not sizes or sizes[0] != n:
        return None
    hypotheses = _SEEDS * len(_TRANSFORMS) * len(sizes)
    if end < m:
        # Other components (passed through): no vertex of the grid's, all smaller, and read
        # as the order-free reader reads them (a seed cell there costs hypotheses; one that
        # holds a grid of its own is left to that reader, which merges readings).
        other_faces = f[end:]
        in_grid = np.zeros(len(v), dtype=bool)
        in_grid[f[:end].ravel()] = True
        if in_grid[other_faces].any():
            return None
        used = np.flatnonzero(np.bincount(other_faces.ravel(), minlength=len(v)))
        remap = np.full(len(v), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        other = _Mesh(v[used], remap[other_faces])
        comp_faces = np.bincount(other.label[other.faces[:, 0]], minlength=other.n_components)
        comp_vertices = np.bincount(other.label, minlength=other.n_components)
        if comp_faces.max() >= end or comp_vertices.max() >= grid_vertices:
            return None
        codes = [_code(k) for k in sizes]
        readings = _read_components(other, codes, 8 * min(c.min_bits for c in codes))
        if any(reading.index is not None for _, reading in readings):
            return None
        hypotheses += sum(reading.hypotheses for _, reading in readings)
    _fill_fold_tips(index, table)
    index = index.reshape(n, n)
    return RecoveredGrid(n, index, v[index], hypotheses, 1.0, 1)


# --------------------------------------------------------------------------------------------
# public API


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
    The algorithm is in this module's docstring.  Choices: seed windows of 11 x 11 code cells
    (121 bits at most), 8 seeds per component, matched on exact 5 x 5 keys and at least 40
    agreeing bits connected to the seed (fewer on a grid with fewer code cells, N = 16).  A
    wrong position or orientation agrees on half the bits of a window, so it rarely gets that
    far, and a walk from it meets contradictions.  What is read is always right; what may be
    left unread on a partial grid: pieces too small to hold the code (a few hundred faces),
    pieces across a seam whose windows do not match, and border samples along a cut where a
    fold of the border could not be ruled out.  On the development meshes at N = 128 and
    256, cropped by 10 to 50 %, that is about 0.2 to 0.5 % of the vertices.  A complete grid
    whose faces are still in the order meshwm wrote them is read by a fast path that gives
    the same result (see the module docstring).

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
    # Files as meshwm wrote them (and most pipelines pass them on) list the faces in the
    # grid's order: a fast exact reading, verified, else the order-free one below.
    if size is not None:
        in_order = [check_square_pow2(size, name="size", low=_MIN_SIZE, high=_MAX_SIZE)]
    else:
        try:  # every face counted: the grid comes first, other components after it
            n_faces = _size_from_faces(len(f))
            in_order = [n_faces, n_faces // 2] if n_faces > _MIN_SIZE else [n_faces]
        except GridError:  # more faces than any grid: the components decide (below)
            in_order = []
    for n_try in in_order:
        fast = _read_in_order(v, f, n_try, size)
        if fast is not None:
            return fast
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
    # One N: the one that explains the most faces; then merge, largest component first.
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
        _fill_fold_tips(index, table)
    index = index.reshape(n, n)
    found = index >= 0
    gim = np.full((n, n, 3), np.nan)
    gim[found] = v[index[found]]
    return RecoveredGrid(n, index, gim, hypotheses, float(found.mean()), len(merged))
