"""Tests for the propagation (:mod:`meshwm.gim.recover.propagate`) through what it meets: a wrong
diagonal, a missing face, the cuts of a crop (the border phase's caution), reversed winding.

Meshes: the open synthetic grid at N = 64, whole or cropped
(:func:`meshwm.attacks.transforms.crop`).
"""

from __future__ import annotations

import numpy as np
import pytest
from _recover_grids import (
    cell_faces,
    check_cut,
    check_partial,
    compact,
    expected_index,
    shuffle,
    unflip,
)
from numpy.testing import assert_array_equal

from meshwm.attacks.transforms import crop
from meshwm.errors import GridError
from meshwm.gim.code import flipped_cells
from meshwm.gim.recover import recover_grid


@pytest.mark.parametrize("k", [0, 100, 300])
def test_one_code_cell_flipped_back_is_refused(open_grid, k):
    """A wrong diagonal is a contradiction the walk meets: refused, never read around."""
    _, v, f = open_grid
    with pytest.raises(GridError, match="no 64 x 64 geometry-image grid"):
        recover_grid(v, unflip(f, 64, flipped_cells(64)[k : k + 1]))


@pytest.mark.parametrize("cell", [(10, 10), (40, 20)])
def test_face_removed_from_the_interior_still_reads(open_grid, cell):
    """A missing face is tolerated when the walk still reaches every sample around it."""
    gim, v, f = open_grid
    grid = recover_grid(v, np.delete(f, cell_faces(64, *cell).start, axis=0))
    assert_array_equal(grid.gim, gim)


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cropped_sheet_reads_every_surviving_vertex(sheet, fraction, seed):
    v, f, index = sheet
    cv, cf = crop(v, f, seed=seed, fraction=fraction)
    cv2, cf2, inverse = shuffle(cv, cf, seed)
    grid = recover_grid(cv2, cf2)
    assert grid.n == 64
    expected = expected_index(index, v, cv)
    expected = np.where(expected >= 0, inverse[np.maximum(expected, 0)], -1)
    check_cut(grid, expected, cv2, cf2)
    assert check_partial(grid, expected, len(cv)) > 0.95
    assert grid.coverage < 1.0 and grid.hypotheses >= 8


def test_crop_with_the_centre_removed(sheet):
    """A hole where the old centre fiducial was: the code is everywhere else."""
    v, f, index = sheet
    centre = v[f].mean(axis=1)[:, :2] - v[:, :2].mean(axis=0)
    keep = np.linalg.norm(centre, axis=1) > 0.2
    cv, cf = compact(v, f[keep])
    grid = recover_grid(cv, cf)
    check_cut(grid, expected_index(index, v, cv), cv, cf)
    assert grid.index[32, 32] == -1


def test_cropped_sheet_with_reversed_winding(sheet):
    v, f, index = sheet
    cv, cf = crop(v, f, seed=4, fraction=0.3)
    grid = recover_grid(cv, cf[:, ::-1])
    check_cut(grid, expected_index(index, v, cv), cv, cf)
    assert_array_equal(grid.index, recover_grid(cv, cf).index)


def test_partial_result_does_not_depend_on_the_order(sheet):
    v, f, _ = sheet
    cv, cf = crop(v, f, seed=5, fraction=0.4)
    grid = recover_grid(cv, cf)
    for seed in (1, 2):
        v2, f2, inverse = shuffle(cv, cf, seed)
        moved = recover_grid(v2, f2)
        assert_array_equal(moved.index, np.where(grid.index >= 0, inverse[grid.index], -1))
        assert moved.hypotheses == grid.hypotheses
        assert moved.coverage == grid.coverage
