"""Tests for :func:`meshwm.gim.recover.drop_irregular` (:mod:`meshwm.gim.recover.repair`): merged
samples of a welded mesh read as small holes.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from meshwm.gim.recover import drop_irregular, recover_grid


def _weld(v: np.ndarray, f: np.ndarray, pairs: list[tuple[int, int]]):
    """Merge vertex b into a for each pair, as a welding filter does: drop collapsed faces."""
    target = np.arange(len(v))
    for a, b in pairs:
        target[b] = a
    f = target[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return v[used], remap[f], np.flatnonzero(used)


@pytest.mark.parametrize(
    "offsets",
    [
        [(0, 1)],  # grid neighbours
        [(1, 1)],  # across a diagonal
        [(0, 2)],  # two apart: a fold of the surface
        [(0, 1), (1, 1), (0, 2), (2, 0)],  # several at once, far apart
    ],
)
def test_welded_samples_read_as_holes(open_grid, offsets):
    """Interior samples merged into one vertex break the walk; without the faces around the
    irregular vertices the rest reads exactly and only samples near the merges are missing."""
    n = 64
    _, v, f = open_grid
    where = [(20, 20), (40, 30), (25, 45), (45, 12)][: len(offsets)]
    pairs = [
        (i * n + j, (i + di) * n + j + dj) for (i, j), (di, dj) in zip(where, offsets, strict=True)
    ]
    wv, wf, kept = _weld(v, f, pairs)
    rv, rf, kept2 = drop_irregular(wv, wf)
    assert len(rv) >= 0.99 * len(wv)
    grid = recover_grid(rv, rf)
    truth = kept[kept2]  # original sample of each vertex left
    found = grid.index >= 0
    assert_array_equal(truth[grid.index[found]], np.flatnonzero(found.ravel()))
    missing = np.argwhere(~found)
    assert len(missing) <= 16 * len(pairs)
    near = np.array(where)
    assert np.all(np.abs(missing[:, None, :] - near[None]).max(axis=2).min(axis=1) <= 3)


def test_drop_irregular_keeps_a_clean_grid_interior(open_grid):
    _, v, f = open_grid
    rv, rf, _ = drop_irregular(v, f)
    # An open grid's irregular vertices are its four corners' neighbourhoods at most.
    assert len(rv) >= len(v) - 16
    assert recover_grid(rv, rf).n == 64
