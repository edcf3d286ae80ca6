"""Tests for :mod:`meshwm.gim.code`: the grid triangulation and its position code."""

from __future__ import annotations

import numpy as np

from meshwm.gim.code import code_cells, flipped_cells, grid_faces


def test_grid_faces_cover_every_cell_counter_clockwise():
    n = 6
    f = grid_faces(n)
    assert f.shape == (2 * (n - 1) ** 2, 3)
    uv = np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2)
    a, b, c = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(cross == 1)  # every triangle is half a unit cell, counter-clockwise


def test_grid_diagonals_alternate_so_connectivity_shows_the_grid():
    """Interior samples with i + j even have 8 neighbours, the others 4 (a 4-8 mesh), except at
    the flipped code cells, whose corners have 7 and 5; diagonals join two i + j even samples
    except in a flipped code cell, where they join its two odd corners."""
    n = 32
    f = grid_faces(n)
    edges = np.unique(
        np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0
    )
    valence = np.bincount(edges.ravel(), minlength=n * n).reshape(n, n)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    flipped = flipped_cells(n)
    near = np.zeros((n, n), dtype=bool)
    for a in (0, 1):
        for b in (0, 1):
            near[flipped[:, 0] + a, flipped[:, 1] + b] = True
    inner = (i > 0) & (i < n - 1) & (j > 0) & (j < n - 1)
    even = (i + j) % 2 == 0
    assert np.all(valence[inner & ~near & even] == 8)
    assert np.all(valence[inner & ~near & ~even] == 4)
    assert np.all(valence[near & even] == 7)
    assert np.all(valence[near & ~even] == 5)
    parity = ((i + j) % 2).ravel()
    rows, cols = edges // n, edges % n
    diagonal = (np.abs(rows[:, 0] - rows[:, 1]) == 1) & (np.abs(cols[:, 0] - cols[:, 1]) == 1)
    even_pair = (parity[edges[:, 0]] == 0) & (parity[edges[:, 1]] == 0)
    cell = rows.min(axis=1) * n + cols.min(axis=1)
    in_code = np.isin(cell, flipped[:, 0] * n + flipped[:, 1]) & diagonal
    assert np.array_equal(diagonal & ~in_code, even_pair & ~in_code)
    assert not np.any(even_pair[in_code])  # a flipped cell's diagonal joins its odd corners


def test_code_cells_keep_off_the_border_and_share_no_sample():
    n = 64
    cells = code_cells(n)
    shifts = np.array([[0, 0], [0, 1], [1, 0], [1, 1]])
    corners = (cells[None, :, :] + shifts[:, None, :]).reshape(-1, 2)
    assert len(np.unique(corners[:, 0] * n + corners[:, 1])) == 4 * len(cells)
    assert corners.min() >= 2 and corners.max() <= n - 3
