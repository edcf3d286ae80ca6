"""Propagation by oriented triangles: from a matched seed to the sample -> vertex map.

When two samples p, q of a grid triangle (p, q, r) are known as vertices u, v, the one face with
the directed edge u -> v is that triangle and its third vertex is sample r.  The interior goes
first, by whole rows of cells (:func:`_sweep`) then breadth first (:func:`_interior`); then the
border ring, most trusted rows first (:func:`_border_phase`, with :func:`_sound` on a partial
grid); then back into the interior through the border; :func:`_walk` repeats until nothing new.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.recover.adjacency import _Lookup
from meshwm.gim.recover.table import _GridTable


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
        js_ = np.tile(cols, len(turn))
        if not step(spin[ts, is_, js_], spin_ac[ts, is_, js_]):
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
    :class:`~meshwm.gim.recover.adjacency._Mesh`) the rows with one of p, q interior are
    limited to the ones :func:`_sound` keeps, and rows with p and q both on the border (the
    corner cells of the square) may only land on a vertex whose one face is the one found (a
    corner sample of an open grid).
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
