"""Tests for the fast path (:mod:`meshwm.gim.recover.fast`): faces in the order meshwm wrote them
give the reading the order-free reader makes, hypotheses count included, or no fast reading.
"""

from __future__ import annotations

import numpy as np
import pytest
from _recover_grids import MESHES, SIZE, synthetic_gim
from numpy.testing import assert_array_equal

import meshwm.gim.recover.read as read_module
import meshwm.gim.recover.sizes as sizes_module
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid
from meshwm.gim.to_mesh import geometry_image_to_mesh


def _order_free(monkeypatch, v, f, **kwargs):
    """recover_grid without the face-order fast path."""
    with monkeypatch.context() as m:
        m.setattr(read_module, "_read_in_order", lambda *a: None)
        return recover_grid(v, f, **kwargs)


def _spy(monkeypatch) -> list[bool]:
    """Record whether each fast-path attempt succeeded."""
    calls: list[bool] = []
    real = read_module._read_in_order

    def spy(*args):
        got = real(*args)
        calls.append(got is not None)
        return got

    monkeypatch.setattr(read_module, "_read_in_order", spy)
    return calls


def _assert_same_reading(a, b) -> None:
    assert (a.n, a.hypotheses, a.coverage, a.components) == (
        b.n,
        b.hypotheses,
        b.coverage,
        b.components,
    )
    assert_array_equal(a.index, b.index)
    assert_array_equal(a.gim, b.gim)


@pytest.mark.parametrize("name", MESHES)
def test_fast_path_reads_what_the_order_free_reader_reads(welded, name, monkeypatch):
    """Welded seams, collapsed border triangles, fold tips: the same reading, taken fast."""
    _, v, f = welded(name)
    slow = _order_free(monkeypatch, v, f)
    calls = _spy(monkeypatch)
    fast = recover_grid(v, f)
    assert calls and calls[-1]  # the fast path read it
    _assert_same_reading(fast, slow)


def test_fast_path_on_the_open_grid_and_with_size(open_grid, monkeypatch):
    gim, v, f = open_grid
    slow = _order_free(monkeypatch, v, f, size=64)
    calls = _spy(monkeypatch)
    for kwargs in ({}, {"size": 64}):
        fast = recover_grid(v, f, **kwargs)
        assert calls[-1]
        _assert_same_reading(fast, slow if kwargs else _order_free(monkeypatch, v, f))
    assert_array_equal(fast.gim, gim)


def test_fast_path_with_other_components_counts_their_hypotheses(monkeypatch):
    """Passed-through components after the grid: read (and counted) as the order-free
    reader reads them; one that holds a grid of its own is left to that reader."""
    n = 32
    gim = synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    extra_v, extra_f = geometry_image_to_mesh(synthetic_gim(24) + np.array([5.0, 0.0, 0.0]))
    both_v = np.concatenate([v, extra_v])
    both_f = np.concatenate([f, extra_f + len(v)])
    slow = _order_free(monkeypatch, both_v, both_f)
    calls = _spy(monkeypatch)
    fast = recover_grid(both_v, both_f)
    _assert_same_reading(fast, slow)
    assert any(calls)
    assert fast.hypotheses > recover_grid(v, f).hypotheses  # the extra piece's seeds count
    # A second grid after the first: the order-free reader decides.
    second_v, second_f = geometry_image_to_mesh(synthetic_gim(n) + np.array([5.0, 0.0, 0.0]))
    two_v = np.concatenate([v, second_v])
    two_f = np.concatenate([f, second_f + len(v)])
    calls.clear()
    got = recover_grid(two_v, two_f)
    assert not any(calls)
    _assert_same_reading(got, _order_free(monkeypatch, two_v, two_f))


@pytest.mark.parametrize("name", MESHES)
def test_fast_path_declines_what_it_cannot_verify(welded, name, monkeypatch):
    """Faces out of order, corners rotated, winding reversed, an interior face gone or two
    swapped: no fast reading, and the order-free reader's result stands."""
    _, v, f = welded(name)
    n = SIZE
    rotated = f.copy()
    rotated[5000] = rotated[5000, [1, 2, 0]]
    swapped = f.copy()
    swapped[[4000, 4001]] = swapped[[4001, 4000]]
    w = 2 * (n - 1)
    interior = 60 * w + 2 * 60  # first face of cell (60, 60)
    cases = {
        "reversed": f[::-1],
        "winding": f[:, ::-1],
        "rotated": rotated,
        "swapped": swapped,
        "missing": np.delete(f, interior, axis=0),
    }
    for label, faces in cases.items():
        calls = _spy(monkeypatch)
        try:
            got = recover_grid(v, faces)
        except GridError:
            got = None
        assert not any(calls), label
        monkeypatch.undo()
        try:
            want = _order_free(monkeypatch, v, faces)
        except GridError:
            want = None
        if want is None:
            assert got is None, label
        else:
            _assert_same_reading(got, want)


def test_many_faces_in_other_components_still_read(monkeypatch):
    """More faces in all than the largest grid has (here: with the largest grid made 64):
    the size comes from the largest component, fast path or not."""
    monkeypatch.setattr(sizes_module, "_MAX_SIZE", 64)
    n = 32
    gim = synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    k = 2 * 63**2 + 1 - len(f)  # loose triangles, so that the total exceeds 2 * 63^2
    rng = np.random.default_rng(3)
    soup_v = rng.normal(size=(3 * k, 3)) + 10.0
    soup_f = np.arange(3 * k).reshape(k, 3) + len(v)
    both_v, both_f = np.concatenate([v, soup_v]), np.concatenate([f, soup_f])
    assert len(both_f) > 2 * 63**2
    grid = recover_grid(both_v, both_f)
    assert grid.n == n and grid.coverage == 1.0
    assert_array_equal(grid.gim, gim)
    _assert_same_reading(grid, _order_free(monkeypatch, both_v, both_f))
