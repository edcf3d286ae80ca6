"""Tests for the grid sizes tried (:mod:`meshwm.gim.recover.sizes`): the code decides N, and a
given ``size`` is checked.
"""

from __future__ import annotations

import pytest
from _recover_grids import check_cut, expected_index
from numpy.testing import assert_array_equal

from meshwm.attacks.transforms import crop
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid


def test_cropped_mesh_gives_n_by_the_code_not_the_face_count(sheet):
    """A fifth of the faces fit a 32-grid; 32 is tried first and the code says 64."""
    v, f, index = sheet
    cv, cf = crop(v, f, seed=1, fraction=0.8)
    assert 2 * 31**2 >= len(cf)
    grid = recover_grid(cv, cf)
    assert grid.n == 64
    assert grid.hypotheses % 3 == 0  # sizes 32, 64 and 128 tried
    check_cut(grid, expected_index(index, v, cv), cv, cf)
    sized = recover_grid(cv, cf, size=64)
    assert_array_equal(sized.index, grid.index)
    assert sized.hypotheses < grid.hypotheses
    with pytest.raises(GridError):
        recover_grid(cv, cf, size=32)


def test_size_is_checked(sheet):
    v, f, _ = sheet
    with pytest.raises(ValueError, match="power of two"):
        recover_grid(v, f, size=100)
