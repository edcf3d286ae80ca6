"""Grouping equal rows (meshwm.mesh.edges): the definitions they replace, on random tables."""

import numpy as np
import pytest

from meshwm.mesh import edges as edges_module
from meshwm.mesh.edges import (
    _odd_vertices,
    _row_order,
    border_half_edges,
    distinct_rows,
    rows_all_distinct,
    unique_rows,
)


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


@pytest.mark.parametrize("seed", range(6))
def test_row_order_is_lexsort_with_few_or_many_ties(seed):
    # Few ties (a scan): the first column's sort, then only its tied rows; many (quantised):
    # np.lexsort itself.  Either way np.lexsort's order, equal rows in their own order.
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 20000))
    v = rng.normal(size=(n, 3))
    pick = rng.integers(0, n, n // 50)
    v[pick, 0] = v[rng.integers(0, n, len(pick)), 0]  # some first values tied
    v[rng.integers(0, n, n // 100)] = v[rng.integers(0, n, n // 100)]  # some whole rows
    v[rng.integers(0, n, n // 100), 0] = -0.0
    v[rng.integers(0, n, n // 100), 0] = 0.0
    for rows in (v, np.round(v * 4) / 4):
        assert np.array_equal(_row_order(rows), np.lexsort(rows.T[::-1]))
        values, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        got_first, got_inverse = unique_rows(rows)
        assert np.array_equal(rows[got_first], values)
        assert np.array_equal(got_first, first)
        assert np.array_equal(got_inverse, inverse.ravel())


@pytest.mark.parametrize("n", [0, 1, 2])
def test_unique_rows_of_no_one_or_two_float_rows(n):
    rows = np.arange(3.0 * n).reshape(n, 3)[::-1].copy()
    first, inverse = unique_rows(rows)
    assert first.tolist() == list(range(n))[::-1]
    assert inverse.tolist() == list(range(n))[::-1]


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


@pytest.mark.parametrize("keep_order", [True, False])
def test_unique_edges_and_their_corner_order_are_the_plain_definitions(keep_order, monkeypatch):
    """Kept for the last faces (read-only) and handed out again: the same as computed afresh,
    whether the corner-edges' order is kept with them or sorted on demand."""
    from meshwm.mesh import edges as module
    from meshwm.mesh.edges import corner_edges_by_edge, unique_edges

    if not keep_order:
        monkeypatch.setattr(module, "_ORDER_MEMO_SIZE", 0)
    rng = np.random.default_rng(3)
    for _ in range(40):
        f = rng.integers(0, int(rng.integers(3, 30)), (int(rng.integers(1, 50)), 3))
        a = f.ravel()
        b = np.roll(f, -1, axis=1).ravel()
        pairs = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
        want, inverse = np.unique(pairs, axis=0, return_inverse=True)
        for copy in (f, f.copy()):  # the second a kept result for an equal array
            edges, got = unique_edges(copy)
            assert np.array_equal(edges, want) and np.array_equal(got, inverse.ravel())
            order = corner_edges_by_edge(copy)
            assert np.array_equal(order, np.argsort(inverse.ravel(), kind="stable"))
            assert not edges.flags.writeable and not got.flags.writeable


def test_unique_edges_not_kept_leave_the_kept_ones():
    """``keep=False``: the same arrays, and the faces kept before are still the kept ones."""
    from meshwm.mesh import edges as module
    from meshwm.mesh.edges import unique_edges

    rng = np.random.default_rng(8)
    kept = rng.integers(0, 40, (60, 3))
    once = rng.integers(0, 40, (70, 3))
    first = unique_edges(kept)
    fresh = module._unique_edges(once)
    edges, inverse = unique_edges(once, keep=False)
    assert np.array_equal(edges, fresh[0]) and np.array_equal(inverse, fresh[1])
    assert not edges.flags.writeable and not inverse.flags.writeable
    again = unique_edges(kept)  # handed out again, not computed
    assert again[0] is first[0] and again[1] is first[1]
    assert unique_edges(once, keep=False)[0] is not edges  # not kept: computed again


def test_distinct_rows_kept_for_the_same_bytes_only():
    v = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 0.0]])
    first, inverse = distinct_rows(v)
    assert not first.flags.writeable
    moved = v.copy()
    moved[2, 0] = 3.0  # other bytes: computed again, not the kept groups
    assert distinct_rows(moved)[1].tolist() == [0, 1, 2]
    assert distinct_rows(v.copy())[1].tolist() == inverse.tolist() == [0, 1, 0]


@pytest.mark.parametrize("seed", range(20))
def test_border_half_edges_are_those_without_a_reverse(seed, plane_mesh):
    # Random faces (repeated corners, both windings, fans) and a mesh with holes whose
    # faces are partly flipped: only faces at a vertex with a border are searched, and
    # nothing is lost or added.
    rng = np.random.default_rng(seed)
    if seed % 2:
        f = rng.integers(0, 12 if seed % 4 == 1 else 300, (40 if seed % 4 == 1 else 900, 3))
    else:
        f = np.asarray(plane_mesh[1], dtype=np.int64)[rng.random(len(plane_mesh[1])) < 0.9]
        flip = rng.random(len(f)) < 0.02
        f[flip] = f[flip][:, ::-1]
    half = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    present = {tuple(h) for h in half.tolist()}
    want = [h for h in half.tolist() if (h[1], h[0]) not in present]
    assert border_half_edges(f).tolist() == want
    assert border_half_edges(f[:0]).shape == (0, 2)
    # The last faces' answer is kept by their bytes: the same again, read-only; other faces
    # (one turned over) are searched afresh.
    again = border_half_edges(f.copy())
    assert again.tolist() == want and not again.flags.writeable
    g = f.copy()
    g[0] = g[0, ::-1]
    half = np.concatenate([g[:, [0, 1]], g[:, [1, 2]], g[:, [2, 0]]])
    present = {tuple(h) for h in half.tolist()}
    assert border_half_edges(g).tolist() == [
        h for h in half.tolist() if (h[1], h[0]) not in present
    ]


@pytest.mark.parametrize("seed", range(6))
def test_odd_vertices_are_those_whose_outgoing_and_incoming_neighbours_differ(seed, plane_mesh):
    # Closed fans (the plane's inside), borders, flipped faces and random fans; the sums agree
    # exactly where the multisets agree (a vertex where they differ but the sums agree would
    # be a hash collision, which these sizes do not meet).
    rng = np.random.default_rng(seed)
    if seed % 2:
        f = rng.integers(0, 30, (80, 3))
    else:
        f = np.asarray(plane_mesh[1], dtype=np.int64)[rng.random(len(plane_mesh[1])) < 0.95]
        flip = rng.random(len(f)) < 0.02
        f[flip] = f[flip][:, ::-1]
    n = int(f.max()) + 1
    outgoing: list[list[int]] = [[] for _ in range(n)]
    incoming: list[list[int]] = [[] for _ in range(n)]
    for face in f.tolist():
        for j in range(3):
            outgoing[face[j]].append(face[(j + 1) % 3])
            incoming[face[j]].append(face[(j + 2) % 3])
    want = [sorted(o) != sorted(i) for o, i in zip(outgoing, incoming, strict=True)]
    got = _odd_vertices(np.asarray(f, dtype=np.int64), n)
    assert got.tolist() == want
    assert sum(want) > 0 and (seed % 2 or sum(want) < n)  # the plane's inside is not odd


@pytest.mark.parametrize("dtype", [np.float64, np.int64])
def test_hashed_groups_number_by_first_appearance_on_every_path(dtype, monkeypatch):
    # Rows that are all distinct take a plain sort; the groups, their numbering and each
    # group's first row are the stable sort's (forced by declaring some key a tie).
    from meshwm.mesh import edges

    rng = np.random.default_rng(3)
    distinct = rng.integers(0, 50, size=(5000, 3)).astype(dtype)
    distinct = distinct[edges.unique_rows(distinct)[0]]
    repeated = np.concatenate([distinct, distinct[::7]])
    fast = [edges._hashed_groups(x) for x in (distinct, repeated)]
    monkeypatch.setattr(edges, "_all_distinct", lambda key: False)
    slow = [edges._hashed_groups(x) for x in (distinct, repeated)]
    # Every hash tied (a collision): the rows themselves decide, with the same numbering.
    monkeypatch.setattr(edges, "_row_hash", lambda bits: np.zeros(len(bits), np.int64))
    collided = [edges._hashed_groups(x) for x in (distinct, repeated)]
    for a, b, c in zip(fast, slow, collided, strict=True):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_array_equal(a[0], c[0])
        np.testing.assert_array_equal(a[1], c[1])
    assert len(fast[0][0]) == len(distinct) and len(fast[1][0]) == len(distinct)
    # Numbered by first appearance: each row its own group where all are distinct, and the
    # repeated rows in the groups of their first copies.
    np.testing.assert_array_equal(fast[0][0], np.arange(len(distinct)))
    np.testing.assert_array_equal(fast[0][1], np.arange(len(distinct)))
    np.testing.assert_array_equal(fast[1][0], np.arange(len(distinct)))
    np.testing.assert_array_equal(fast[1][1][len(distinct) :], np.arange(0, len(distinct), 7))


@pytest.mark.parametrize("seed", range(5))
def test_rows_all_distinct_is_whether_every_row_is_its_own_group(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    v = _table(rng)
    every = np.unique(v.view(np.uint64), axis=0).shape[0] == len(v)
    assert rows_all_distinct(v) == every
    spread = np.column_stack([v, np.arange(len(v))])  # distinct rows
    assert rows_all_distinct(spread)
    # Hashes that all tie (a collision): the rows themselves decide.
    monkeypatch.setattr(edges_module, "_row_hash", lambda bits: np.zeros(len(bits), np.int64))
    assert rows_all_distinct(v) == every
    assert rows_all_distinct(spread)
