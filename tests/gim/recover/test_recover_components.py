"""Tests for reading each component (:mod:`meshwm.gim.recover.components`) and merging them: pieces
left by a cut or a crop, pieces too small, other components passed through.
"""

from __future__ import annotations

import numpy as np
import pytest
from _recover_grids import SIZE, check_cut, check_partial, compact, expected_index
from numpy.testing import assert_array_equal

from meshwm.attacks.transforms import crop
from meshwm.gim.recover import recover_grid
from meshwm.gim.to_mesh import geometry_image_to_mesh


def test_pieces_are_read_and_merged(sheet):
    """Two bands removed: three components, each seeded and read on its own, then merged."""
    v, f, index = sheet
    x = v[f].mean(axis=1)[:, 1]
    keep = ~(((x > 0.3) & (x < 0.35)) | ((x > 0.65) & (x < 0.7)))
    cv, cf = compact(v, f[keep])
    grid = recover_grid(cv, cf)
    assert grid.components == 3
    check_cut(grid, expected_index(index, v, cv), cv, cf)


def test_small_piece_is_ignored(sheet):
    """A piece too small to hold a few dozen code bits is left out (its samples read -1)."""
    v, f, index = sheet
    x = v[f].mean(axis=1)[:, 1]
    keep = (x < 0.6) | (x > 0.65)
    keep &= ~((x > 0.65) & (v[f].mean(axis=1)[:, 0] > 0.1))  # a strip 3 samples wide is left
    cv, cf = compact(v, f[keep])
    grid = recover_grid(cv, cf)
    assert grid.components == 1
    expected = expected_index(index, v, cv)
    found = grid.index >= 0
    assert_array_equal(grid.index[found], expected[found])
    assert np.all(grid.index[:, 42:] == -1)


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cropped_welded_mesh_has_no_false_sample(welded, fraction, seed):
    """Spot at N = 128: a crop can leave pieces connected only across a welded seam, which
    are seeded again; every sample read is right, and nearly every vertex is read."""
    _, v, f = welded("spot_mesh")
    full = recover_grid(v, f)
    cv, cf = crop(v, f, seed=seed, fraction=fraction)
    grid = recover_grid(cv, cf)
    assert grid.n == SIZE
    # Fold tips were filled from a neighbour in the complete reading: they are no sample here.
    expected = expected_index(full.index, v, cv)
    read = check_partial(grid, expected, len(cv))
    assert read >= 0.97


def test_other_components_with_many_faces_do_not_hide_the_size():
    """meshwm passes other components through; their faces must not push N up a size."""
    n = 32
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    gim = np.stack([i, j, np.sin(i + j)], axis=-1).astype(float)
    v, f = geometry_image_to_mesh(gim)
    extra_v, extra_f = geometry_image_to_mesh(gim[:24, :24] + [100.0, 0.0, 0.0])
    both_v = np.concatenate([v, extra_v])
    both_f = np.concatenate([f, extra_f + len(v)])
    assert len(both_f) > 2 * (n - 1) ** 2  # the face count alone would say N = 64
    grid = recover_grid(both_v, both_f)
    assert grid.n == n and grid.coverage == 1.0
    assert np.array_equal(grid.gim, gim)
