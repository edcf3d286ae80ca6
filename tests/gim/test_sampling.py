"""Tests for :mod:`meshwm.gim.sampling`: the sparse barycentric sampling on the N×N grid."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.gim import sampling as sampling_module
from meshwm.gim.code import grid_faces
from meshwm.gim.sampling import (
    Sampling,
    bilinear_matrix,
    grid_points,
    locate_grid_points,
    sampling_matrix,
)

N = 33


@pytest.fixture(scope="module")
def jittered_square() -> tuple[np.ndarray, np.ndarray]:
    """The unit square as a 12 × 12 vertex grid in z = 0, interior vertices jittered."""
    rng = np.random.default_rng(13)
    k = 12
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    xy = np.stack([j.ravel(), i.ravel()], axis=1) / (k - 1)
    inner = ((i > 0) & (i < k - 1) & (j > 0) & (j < k - 1)).ravel()
    xy[inner] += rng.uniform(-0.3, 0.3, (int(inner.sum()), 2)) / (k - 1)
    return np.column_stack([xy, np.zeros(k * k)]), grid_faces(k)


def test_sampling_a_flat_square_with_uv_xy_gives_the_grid_points(jittered_square):
    v, f = jittered_square
    s = sampling_matrix(v[:, :2], f, N)
    assert isinstance(s, Sampling) and sp.issparse(s.matrix)
    assert s.matrix.shape == (N * N, len(v)) and s.covered.shape == (N, N)
    assert s.covered.all()
    expected = np.column_stack([grid_points(N), np.zeros(N * N)])
    assert_allclose(s.matrix @ v, expected, rtol=0, atol=1e-12)
    assert_allclose(np.asarray(s.matrix.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)
    assert s.matrix.getnnz(axis=1).max() <= 3


def test_the_rows_are_row_major_in_i_then_j():
    g = grid_points(4).reshape(4, 4, 2)
    assert_allclose(g[1, 3], [1.0, 1 / 3], rtol=0, atol=1e-15)  # (u, v) = (j, i) / (N - 1)


def test_vertex_and_face_order_change_nothing(jittered_square):
    v, f = jittered_square
    rng = np.random.default_rng(7)
    reference = sampling_matrix(v[:, :2], f, N).matrix.toarray()
    perm = rng.permutation(len(v))  # new vertex k is old vertex perm[k]
    inverse = np.argsort(perm)
    faces = inverse[f][rng.permutation(len(f))]
    faces = np.roll(faces, 1, axis=1)  # rotate each triangle's corners too
    s = sampling_matrix(v[perm, :2], faces, N)
    assert_allclose(s.matrix.toarray()[:, inverse], reference, rtol=0, atol=1e-12)
    assert s.covered.all()


def test_points_outside_every_triangle_are_uncovered_with_empty_rows():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # the lower-left half only
    s = sampling_matrix(uv, np.array([[0, 1, 2]]), 9)
    g = grid_points(9).reshape(9, 9, 2)
    assert_array_equal(s.covered, g.sum(axis=-1) <= 1.0 + 1e-12)
    rows = s.matrix.getnnz(axis=1).reshape(9, 9)
    assert (rows[~s.covered] == 0).all() and (rows[s.covered] > 0).all()
    assert_allclose(s.matrix[s.covered.ravel()] @ uv, g[s.covered], rtol=0, atol=1e-12)


def test_a_degenerate_triangle_interpolates_along_its_longest_edge():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.25, 0.0]])  # three collinear corners
    s = sampling_matrix(uv, np.array([[0, 1, 2]]), 5)
    assert s.covered[0].all()
    assert not s.covered[1:].any()
    assert_allclose(s.matrix[:5] @ uv, grid_points(5)[:5], rtol=0, atol=1e-12)
    assert_allclose(np.asarray(s.matrix[:5].sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("uv", "faces", "n", "match"),
    [
        (np.zeros((4, 3)), [[0, 1, 2]], 4, "uv must have shape"),
        (np.zeros(4), [[0, 1, 2]], 4, "uv must have shape"),
        ([[0, 0], [1, 0], [np.nan, 1]], [[0, 1, 2]], 4, "uv has NaN"),
        ([[0, 0], [1, 0], [0, np.inf]], [[0, 1, 2]], 4, "uv has NaN"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1, 3]], 4, "faces must index"),
        ([[0, 0], [1, 0], [0, 1]], [[0, -1, 2]], 4, "faces must index"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1]], 4, "faces must be triangles"),
        ([[0, 0], [1, 0], [0, 1]], np.zeros((0, 3), np.int64), 4, "faces must be triangles"),
        ([[0, 0], [1, 0], [0, 1]], [[0.0, 1.0, 2.0]], 4, "faces must hold integer"),
        ([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], 1, "n must be >= 2"),
    ],
)
def test_bad_input_raises_a_value_error_naming_the_parameter(uv, faces, n, match):
    with pytest.raises(ValueError, match=match):
        sampling_matrix(np.asarray(uv, dtype=float), np.asarray(faces), n)


def test_a_non_integer_size_raises_a_type_error():
    with pytest.raises(TypeError, match="n must be an integer"):
        sampling_matrix(np.eye(3)[:, :2], np.array([[0, 1, 2]]), 4.0)  # type: ignore[arg-type]


def test_a_negative_tolerance_raises():
    with pytest.raises(ValueError, match="tolerance"):
        sampling_matrix(np.eye(3)[:, :2], np.array([[0, 1, 2]]), 4, tolerance=-1.0)


@pytest.mark.parametrize("seed", range(5))
def test_only_triangles_near_grid_points_are_searched_and_nothing_is_lost(seed):
    # Many small triangles, some beyond the unit square, most holding no grid point: every
    # grid point inside the triangulation is covered and interpolates to itself.
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    uv = rng.uniform(0.03, 1.2, size=(3000, 2))  # the grid's first row and column uncovered
    faces = Delaunay(uv).simplices.astype(np.int64)
    n = 17
    s = sampling_matrix(uv, faces, n)
    points = grid_points(n)
    inside = Delaunay(uv).find_simplex(points) >= 0
    assert 0 < inside.sum() < len(points)
    np.testing.assert_array_equal(s.covered.ravel(), inside)
    np.testing.assert_allclose((s.matrix @ uv)[inside], points[inside], atol=1e-12)


def test_bilinear_weights_reproduce_bilinear_fields_and_pick_grid_points():
    rng = np.random.default_rng(5)
    n = 9
    uv = np.concatenate([rng.uniform(0, 1, (200, 2)), [[0, 0], [1, 1], [1, 0], [0, 1]]])
    m = bilinear_matrix(uv, n)
    assert m.shape == (len(uv), n * n) and np.diff(m.indptr).max() <= 4
    assert_allclose(np.asarray(m.sum(axis=1)).ravel(), 1.0)
    g = grid_points(n)
    field = np.column_stack([g, g[:, 0] * g[:, 1], 3 - 2 * g[:, 0] + g[:, 1]])
    want = np.column_stack([uv, uv[:, 0] * uv[:, 1], 3 - 2 * uv[:, 0] + uv[:, 1]])
    assert_allclose(m @ field, want, atol=1e-12)
    # At a grid point the row is that point alone; the transpose of the sampling's convention.
    at = bilinear_matrix(g, n)
    assert_allclose(at.toarray(), np.eye(n * n), atol=1e-12)


@pytest.mark.parametrize(
    ("uv", "n", "match"),
    [
        (np.zeros((3, 3)), 4, "uv must have shape"),
        (np.array([[0.5, np.nan]]), 4, "uv must be finite"),
        (np.zeros((3, 2)), 1, "n must be"),
    ],
)
def test_bilinear_bad_input_raises(uv, n, match):
    with pytest.raises(ValueError, match=match):
        bilinear_matrix(uv, n)


def _holds_exactly(tri: np.ndarray, point: np.ndarray) -> bool:
    """Whether a UV triangle holds a point, in rational arithmetic."""
    from fractions import Fraction

    a, b, c = ([Fraction(float(x)) for x in corner] for corner in tri)
    p = [Fraction(float(x)) for x in point]

    def side(o: list, q: list) -> Fraction:
        return (q[0] - o[0]) * (p[1] - o[1]) - (q[1] - o[1]) * (p[0] - o[0])

    s = [side(a, b), side(b, c), side(c, a)]
    return all(x >= 0 for x in s) or all(x <= 0 for x in s)


@pytest.mark.parametrize("seed", range(4))
def test_located_grid_points_lie_in_their_lowest_triangle_in_exact_arithmetic(seed):
    # A random triangulation of the square (hull slivers included) and a structured one
    # whose edges run through grid points: every grid point is found, in a triangle that
    # holds it exactly, and the lowest-numbered such triangle.
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    if seed % 2:
        uv = rng.uniform(0.0, 1.0, size=(600, 2))
        uv[:4] = [[0, 0], [1, 0], [0, 1], [1, 1]]
        faces = Delaunay(uv).simplices.astype(np.int64)
    else:
        k = 9  # vertices at grid points of N = 33: many points on shared edges and corners
        i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
        uv = np.stack([j.ravel(), i.ravel()], axis=1) / (k - 1)
        faces = grid_faces(k).astype(np.int64)
    faces = faces[rng.permutation(len(faces))]
    found = locate_grid_points(uv, faces, N)
    points = grid_points(N)
    assert (found >= 0).all()
    tri = uv[faces]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    for p in rng.choice(N * N, 150, replace=False):
        boxed = np.flatnonzero(((lo <= points[p]) & (points[p] <= hi)).all(axis=1))
        holding = [t for t in boxed if _holds_exactly(tri[t], points[p])]
        assert found[p] == min(holding)


def test_points_off_the_domain_are_not_located_and_chunks_change_nothing(monkeypatch):
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(5)
    uv = rng.uniform(0.2, 0.9, size=(300, 2))
    faces = Delaunay(uv).simplices.astype(np.int64)
    found = locate_grid_points(uv, faces, N)
    points = grid_points(N)
    off = (points < 0.2).any(axis=1) | (points > 0.9).any(axis=1)
    assert (found[off] == -1).all() and (found[~off] >= -1).all()
    inside = found >= 0
    assert inside.sum() > 0.3 * N * N
    for p in np.flatnonzero(inside)[::7]:
        assert _holds_exactly(uv[faces[found[p]]], points[p])
    monkeypatch.setattr(sampling_module, "_PAIR_CHUNK", 50)  # a few faces' pairs at once
    assert_array_equal(locate_grid_points(uv, faces, N), found)
    monkeypatch.setattr(sampling_module, "_BOX_CHUNK", 37)  # and a few faces per chunk
    assert_array_equal(locate_grid_points(uv, faces, N), found)
