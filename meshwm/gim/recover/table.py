"""The grid side of grid recovery: the triangles of an N-grid and the rows the walk steps by.

:class:`_GridTable` lists the grid triangles as :func:`meshwm.gim.code.grid_faces` writes them,
the border rows with their trust, the re-entry rows, the perimeter neighbours of each border
sample, and the cells in each of their 4 rotations; interior rows are computed on demand from the
positions they touch.  One table per N, cached (:func:`_grid_table`).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.code import grid_faces


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
        self.prev, self.next = _perimeter(n)

    @functools.cached_property
    def spin(self) -> NDArray[np.int64]:
        """Every cell in each of its 4 rotations, for the row sweep (see propagate._sweep):
        ``spin[r]`` is (N-1, N-1, 4) corners A, B, C, D.  Made when first asked for (134 MB
        at N = 1024, and a complete grid read in order never asks)."""
        n = self.n
        ci, cj = np.divmod(np.arange((n - 1) ** 2), n - 1)
        c00 = ci * n + cj
        cycle = [c00, c00 + 1, c00 + n + 1, c00 + n]
        return np.stack(
            [np.stack([cycle[(r + k) % 4] for k in range(4)], axis=-1) for r in range(4)]
        ).reshape(4, n - 1, n - 1, 4)

    @functools.cached_property
    def spin_ac(self) -> NDArray[np.bool_]:
        """Per rotation of :attr:`spin`, whether the cell's A-C corners are its diagonal."""
        main = self.main.reshape(self.n - 1, self.n - 1)
        return np.stack([main, ~main, main, ~main])

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


def _perimeter(n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Each border sample's two neighbours along the perimeter of the N-square (previous, next;
    -1 off the border), the loop running along row 0, column N-1, row N-1 backwards and
    column 0 upwards."""
    loop = np.concatenate(
        [
            np.arange(n),  # row 0, left to right
            np.arange(1, n) * n + n - 1,  # column N-1, downwards
            (n - 1) * n + np.arange(n - 2, -1, -1),  # row N-1, right to left
            np.arange(n - 2, 0, -1) * n,  # column 0, upwards
        ]
    )
    prev = np.full(n * n, -1, dtype=np.int64)
    nxt = np.full(n * n, -1, dtype=np.int64)
    prev[loop] = np.roll(loop, 1)
    nxt[loop] = np.roll(loop, -1)
    return prev, nxt


@functools.lru_cache(maxsize=4)
def _grid_table(n: int) -> _GridTable:
    """The table of an N-grid, cached."""
    return _GridTable(n)
