"""Grouping equal rows (meshwm.mesh.edges): the definitions they replace, on random tables."""

import numpy as np
import pytest

from meshwm.mesh.edges import distinct_rows, unique_rows


def _table(rng: np.random.Generator) -> np.ndarray:
    """Rows with many repeats, signed zeros and values equal in float but not in bits."""
    n = int(rng.integers(1, 300))
    v = rng.integers(-2, 3, (n, 3)).astype(np.float64) * rng.choice([1.0, 0.5, 1e-300], (n, 3))
    v[rng.random((n, 3)) < 0.1] = -0.0
    return v


@pytest.mark.parametrize("seed", range(5))
def test_unique_rows_is_numpys_unique_over_rows(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        v = _table(rng)
        values, first, inverse = np.unique(v, axis=0, return_index=True, return_inverse=True)
        got_first, got_inverse = unique_rows(v)
        assert np.array_equal(v[got_first], values)  # the same rows, in the same order
        assert np.array_equal(got_first, first)  # each one's first occurrence
        assert np.array_equal(got_inverse, inverse.ravel())


@pytest.mark.parametrize("seed", range(5))
def test_distinct_rows_groups_bit_identical_rows_by_first_appearance(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        v = _table(rng)
        bits = v.view(np.uint64)
        first, inverse = distinct_rows(v)
        assert np.all(np.diff(first) > 0)  # first appearances, in the rows' own order
        assert np.array_equal(bits[first][inverse], bits)  # each row is its group's row
        assert len(np.unique(bits, axis=0)) == len(first)  # and groups are bit-distinct
        assert np.array_equal(inverse[first], np.arange(len(first)))  # numbered in order


@pytest.mark.parametrize("seed", range(3))
def test_unique_rows_of_integers_is_numpys_unique_over_rows(seed):
    # The packed-key path: one sort of a key per row, first occurrences as the smallest index.
    rng = np.random.default_rng(seed)
    for _ in range(60):
        v = rng.integers(-3, 4, (int(rng.integers(1, 400)), 3))
        values, first, inverse = np.unique(v, axis=0, return_index=True, return_inverse=True)
        got_first, got_inverse = unique_rows(v)
        assert np.array_equal(v[got_first], values)
        assert np.array_equal(got_first, first)
        assert np.array_equal(got_inverse, inverse.ravel())
