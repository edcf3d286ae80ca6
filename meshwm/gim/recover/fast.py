"""The fast path: a complete grid whose faces are in the order meshwm wrote them.

Each row of interior cells is then a contiguous run of faces, found from the run above it
(:func:`_run_starts`); the border ring is read from the known interior by the same border phase
as the order-free reader (:func:`meshwm.gim.recover.propagate._border_phase`).  Everything is
verified, and the reading, hypotheses count included, is the one the order-free reader makes of
the same mesh (:func:`_read_in_order`).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.code import flipped_cells
from meshwm.gim.recover.adjacency import _Lookup, _Mesh
from meshwm.gim.recover.components import _read_components
from meshwm.gim.recover.matching import _TRANSFORMS, _code
from meshwm.gim.recover.propagate import _border_phase
from meshwm.gim.recover.result import RecoveredGrid
from meshwm.gim.recover.seeds import _SEEDS
from meshwm.gim.recover.sizes import _MIN_SIZE, _candidate_sizes
from meshwm.gim.recover.table import _grid_table
from meshwm.gim.recover.verify import _explained, _fill_fold_tips


class _RunTable(NamedTuple):
    """The interior cells of an N-grid as :func:`meshwm.gim.code.grid_faces` lists them: rows
    of cells 1..N-3, columns 1..N-3, each row a contiguous run of faces; and the border cells'
    faces."""

    runs: NDArray[np.int64]  # (N-3, 2(N-3), 3) the interior triangles, a row of cells per run
    types: NDArray[np.int8]  # (N-3, N-3) per interior cell: 1 diagonal p00-p11, 2 p01-p10
    border_faces: NDArray[np.int64]  # (k, 3) the triangles of the border cells


@functools.lru_cache(maxsize=4)
def _run_table(n: int) -> _RunTable:
    """The run table of an N-grid, cached and read-only."""
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
    """Flipped code cells of an N-grid (cached)."""
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
    c0, c1, c2 = (np.ascontiguousarray(f[:, c]).data for c in range(3))
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

    Every file meshwm writes lists the grid's faces in :func:`~meshwm.gim.code.grid_faces`
    order (less the triangles a welded seam collapsed, all in border cells), then the
    components passed through, and most pipelines keep that order: format conversions,
    transforms, merging duplicate vertices (the vertex order does not matter here).  Then the
    interior cells are contiguous runs of faces, one per row of cells (:func:`_run_starts`),
    and give every interior sample.  The border ring is read exactly as the order-free reader
    reads it on a complete grid, by :func:`~meshwm.gim.recover.propagate._border_phase` from
    the known interior, with a lookup of the faces between the runs (every triangle of a border
    cell is there, and no query can be answered by a face of a run: those have interior
    vertices only, and the directed edges between interior samples that border triangles have
    are not theirs).

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
    grid = np.full((n, n), -1, dtype=np.int64)
    grid[1:-2, 1:-2] = ran[:, 0::2, 0]  # p00 of cells (r, c), 1 <= r, c <= n-3
    grid[1:-2, -2] = ran[:, -2, 1]  # p01 of cells (r, n-3)
    grid[-2, 1:-2] = ran[-1, 1::2, 2]  # p10 of cells (n-3, c)
    grid[-2, -2] = ran[-1, -1, 1]  # p11 of cell (n-3, n-3)
    index = grid.ravel()
    if not np.array_equal(index[runs.runs], ran):
        return None
    # The faces between the runs, and after the last one (to the end: other components are
    # left over below).
    between = np.ones(m, dtype=bool)
    between[(starts[:, None] + np.arange(seg)).ravel()] = False
    rest = np.flatnonzero(between)
    table = _grid_table(n)
    lookup = _Lookup(len(v), f[rest])
    for levels in ((2,), (2, 1, 0)):  # as propagate._walk on a complete interior
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
    _fill_fold_tips(index, table.prev, table.next)
    square = index.reshape(n, n)
    return RecoveredGrid(n, square, v[square], hypotheses, 1.0, 1)
