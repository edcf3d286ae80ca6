"""Tests for the position code as :mod:`meshwm.gim.recover.matching` reads it: its cells, its bits,
no symmetry of the square, and no grid found without it.

The code itself is written by :func:`meshwm.gim.code.code_cells` and
:func:`meshwm.gim.code.flipped_cells`; these are the properties the matching relies on.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from _recover_grids import unflip
from numpy.testing import assert_array_equal

from meshwm.errors import GridError
from meshwm.gim.code import code_cells, flipped_cells
from meshwm.gim.recover import recover_grid


def test_without_the_position_code_no_grid_is_found(open_grid):
    """A plain 4-8 grid has no flipped code cell: nothing to seed from, nothing to orient by."""
    _, v, f = open_grid
    with pytest.raises(GridError, match="0 hypotheses"):
        recover_grid(v, unflip(f, 64, flipped_cells(64)))


@pytest.mark.parametrize("n", [16, 64, 256, 2048])
def test_code_cells_share_no_sample_and_keep_off_the_border(n):
    cells = code_cells(n)
    assert len(cells) == (n // 2 - 2) ** 2
    assert np.all(cells % 2 == 0)
    assert cells.min() >= 2 and cells.max() <= n - 4  # corners 2 .. N-3: off the border ring
    flipped = flipped_cells(n)
    assert 0.3 < len(flipped) / len(cells) < 0.7
    assert np.all(np.isin(flipped[:, 0] * n + flipped[:, 1], cells[:, 0] * n + cells[:, 1]))


def test_code_is_sha256_of_a_public_tag():
    """SHA-256 in counter mode, no random stream: the same bits on every machine, and each N
    has its own code."""
    n = 64
    stream = b"".join(
        hashlib.sha256(b"meshwm/grid/v2/64/" + k.to_bytes(8, "big")).digest() for k in range(4)
    )
    bits = np.unpackbits(np.frombuffer(stream, dtype=np.uint8))[: len(code_cells(n))]
    assert_array_equal(flipped_cells(n), code_cells(n)[bits.astype(bool)])
    cells = code_cells(64)
    key = cells[:, 0] * 1000 + cells[:, 1]
    in_small = np.isin(key, flipped_cells(64)[:, 0] * 1000 + flipped_cells(64)[:, 1])
    in_large = np.isin(key, flipped_cells(128)[:, 0] * 1000 + flipped_cells(128)[:, 1])
    assert not np.array_equal(in_small, in_large)


@pytest.mark.parametrize("n", [16, 32, 64, 128, 256, 512, 1024, 2048])
def test_code_has_no_symmetry_of_the_square(n):
    """No symmetry of the square (other than the identity) maps the flipped cells onto
    themselves, so neither a turned nor a mirrored reading (reversed winding) can verify."""
    flipped = flipped_cells(n)
    key = np.sort(flipped[:, 0] * n + flipped[:, 1])
    i, j = flipped[:, 0], flipped[:, 1]
    m = n - 2  # cell (i, j) -> (m - i, j) etc.: cells map to cells
    images = [
        (j, m - i),
        (m - i, m - j),
        (m - j, i),
        (j, i),
        (m - i, j),
        (m - j, m - i),
        (i, m - j),
    ]
    for a, b in images:
        assert not np.array_equal(np.sort(a * n + b), key)
