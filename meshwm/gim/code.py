"""The grid's triangulation and the position code it carries, shared by writer and reader.

A geometry image is written as a mesh of two triangles per grid cell (:func:`grid_faces`), with
alternating diagonals so that the grid can be read back from connectivity alone, and with the
diagonal of some cells flipped (:func:`flipped_cells`) as a public, keyless *position code* on the
:func:`code_cells`.  :mod:`meshwm.gim.to_mesh` writes this triangulation and
:mod:`meshwm.gim.recover` reads a grid, and where a piece of it lies, from it.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np
from numpy.typing import NDArray

__all__ = ["code_cells", "flipped_cells", "grid_faces"]


_CODE_TAG = b"meshwm/grid/v2/"


@functools.lru_cache(maxsize=16)
def _code_bits(n: int) -> NDArray[np.bool_]:
    """The public position code of an n × n grid: one bit per code cell, row-major (read-only).

    SHA-256 in counter mode: block k is ``sha256(b"meshwm/grid/v2/" + str(n) + b"/" + k)`` with
    k as 8 big-endian bytes; the blocks are concatenated and read most significant bit first.
    No key and no random generator: every machine and every numpy version gets the same bits.
    """
    m = len(range(2, n - 3, 2))
    count = m * m
    tag = _CODE_TAG + str(n).encode() + b"/"
    blocks = b"".join(
        hashlib.sha256(tag + k.to_bytes(8, "big")).digest() for k in range(-(-count // 256))
    )
    bits = np.unpackbits(np.frombuffer(blocks, dtype=np.uint8))[:count].astype(bool)
    bits = bits.reshape(m, m)
    bits.setflags(write=False)
    return bits


def code_cells(n: int) -> NDArray[np.int64]:
    """The cells of an n × n grid whose diagonal carries a bit of the position code.

    They are the cells (i, j) with i and j both even and 2 <= i, j <= n - 4, in row-major
    order: no two share a sample (so every sample lies in at most one of them), and none
    touches the border of the grid (border cells are the only ones a welded seam can collapse,
    and :mod:`meshwm.gim.recover` handles them by their fixed diagonals).

    Parameters
    ----------
    n : int
        Grid size N.

    Returns
    -------
    (k, 2) int64 ndarray
        Row and column of each code cell's corner p00; ``k = (N/2 - 2)^2`` for even N.

    Examples
    --------
    >>> code_cells(8).tolist()
    [[2, 2], [2, 4], [4, 2], [4, 4]]
    """
    steps = np.arange(2, n - 3, 2, dtype=np.int64)
    i, j = np.meshgrid(steps, steps, indexing="ij")
    return np.stack([i.ravel(), j.ravel()], axis=1)


def flipped_cells(n: int) -> NDArray[np.int64]:
    """The code cells whose diagonal is flipped: the position code of an n × n grid.

    Each code cell (see :func:`code_cells`) is flipped iff its bit of a public, keyless code is 1.
    The bits are SHA-256 in counter mode over the tag ``b"meshwm/grid/v2/" + str(n)`` (hashlib
    only, never a random generator), so every machine writes and reads the same code, and the
    code of one N differs from the code of any other: the code tells N too.

    Parameters
    ----------
    n : int
        Grid size N.

    Returns
    -------
    (m, 2) int64 ndarray
        Row and column of each flipped cell's corner p00, row-major; about half the code cells.

    Notes
    -----
    A flipped code cell (i, j) has the diagonal p01-p10 although i + j is even, so it joins two
    samples with i + j odd.  Those two get 5 neighbours instead of 4, the other two corners 7
    instead of 8.  Since code cells share no sample, every interior sample touches at most
    one flipped cell: the valences stay in {7, 8} for i + j even and {4, 5} for i + j odd, and a
    flipped cell is recognisable locally (a diagonal between two valence-5 samples whose
    triangles' third corners have valence 7).  Any window of a few dozen code cells is, with
    overwhelming probability, found nowhere else in the code, in no orientation or mirror image,
    and in the code of no other N; so a piece of the grid tells where it is
    (:func:`meshwm.gim.recover.recover_grid`).
    """
    return code_cells(n)[_code_bits(n).ravel()]


def grid_faces(n: int) -> NDArray[np.int64]:
    """The two triangles of every grid cell, counter-clockwise in (u, v), diagonals alternating
    (read-only: one array per size, shared; at N = 1024 two million triangles, 45 ms to build,
    asked for by the embedding's output and its read-back).

    Cell (i, j) has corners ``p00 = i*N + j``, ``p01 = p00 + 1``, ``p10 = p00 + N`` and
    ``p11 = p10 + 1``.  Where i + j is even its diagonal is p00-p11, triangles (p00, p01, p11)
    and (p00, p11, p10); where it is odd the diagonal is p01-p10, triangles (p00, p01, p10)
    and (p01, p11, p10).  The :func:`flipped_cells` (a position code on the cells with i and j
    both even, off the border) take the other diagonal.

    Notes
    -----
    Alternating diagonals (a "4-8" triangulation) make the grid readable from connectivity
    alone: samples with i + j even have 8 neighbours, the others 4.

    The flipped code cells change that to 7 and 5 around them.  They are a *position code*:
    the pattern of flipped cells in any patch of a few dozen code cells occurs nowhere else,
    in no orientation, so blind extraction (:mod:`meshwm.gim.recover`) can tell from any large
    enough piece of the mesh (a cropped copy, one of several pieces) which grid samples its vertices
    are, and read the rest one triangle at a time.  Only the triangulation of some cells
    changes, not a single sample, so the surface moves by no more than the non-planarity of a
    grid quad.
    """
    return _grid_faces(int(n))


def border_cell_faces(n: int) -> NDArray[np.int64]:
    """The triangles of the cells along the border of an N-grid (cell row or column 0 or
    N - 2): the rows of :func:`grid_faces` for those cells, in its order, without building it.

    No code cell touches the border, so these cells keep the alternating diagonals.

    Examples
    --------
    >>> n = 16
    >>> cell = np.arange(2 * (n - 1) ** 2) // 2
    >>> i, j = np.divmod(cell, n - 1)
    >>> ring = (i == 0) | (j == 0) | (i == n - 2) | (j == n - 2)
    >>> bool(np.array_equal(border_cell_faces(n), grid_faces(n)[ring]))
    True
    """
    n = int(n)
    i, j = np.divmod(np.arange((n - 1) ** 2), n - 1)
    ring = (i == 0) | (j == 0) | (i == n - 2) | (j == n - 2)
    i, j = i[ring], j[ring]
    return _cell_faces(i * n + j, n, (i + j) % 2 == 0)


def _cell_faces(p00: NDArray[np.int64], n: int, main: NDArray[np.bool_]) -> NDArray[np.int64]:
    """The two triangles of each cell with first corner ``p00`` (see :func:`grid_faces`),
    ``main`` where its diagonal is p00-p11."""
    p00 = np.asarray(p00, dtype=np.int64)
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    # Written corner by corner into the output (at N = 1024 two million triangles: 74 ms
    # through stacked temporaries of every candidate triangle, cold).
    out = np.empty((len(p00), 2, 3), dtype=np.int64)
    out[:, 0, 0] = p00
    out[:, 0, 1] = p01
    out[:, 0, 2] = np.where(main, p11, p10)
    out[:, 1, 0] = np.where(main, p00, p01)
    out[:, 1, 1] = p11
    out[:, 1, 2] = p10
    return out.reshape(-1, 3)


@functools.lru_cache(maxsize=4)
def _grid_faces(n: int) -> NDArray[np.int64]:
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    even = (i + j) % 2 == 0
    flip = flipped_cells(n)
    even[flip[:, 0], flip[:, 1]] = False
    faces = _cell_faces((i * n + j).ravel(), n, even.ravel())
    faces.setflags(write=False)
    return faces
