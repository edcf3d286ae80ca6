"""Tests for :mod:`meshwm.gim.parameterize`: the map of the disk onto the unit square."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import meshwm.gim.parameterize as parameterize
from meshwm.gim.boundary import boundary_chains, split_corners, unit_to_uv
from meshwm.gim.cut import area_centroid, cut_open, edge_graph, initial_cut
from meshwm.gim.parameterize import (
    GridStep,
    flat_faces,
    grid_step,
    signed_uv_area,
    stretch_parameterize,
)
from meshwm.mesh.clean import unique_edges

N = 64


def _disk(v, f, paths):
    cut = cut_open(v, f, paths)
    radial = np.linalg.norm(v - area_centroid(v, f), axis=1)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, N, radial)
    disk = split_corners(cut.vertices, cut.faces, cut.origin, chains, N)
    return disk, unit_to_uv(disk.unit, N)


def test_signed_uv_area_is_positive_counter_clockwise():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert signed_uv_area(uv, np.array([[0, 1, 2], [0, 2, 1]])).tolist() == [0.5, -0.5]


def test_harmonic_map_of_a_flat_square_is_the_identity(flat_square):
    v, f = flat_square
    disk, boundary_uv = _disk(v, f, [])
    uv, history = stretch_parameterize(
        disk.vertices, disk.faces, disk.loop, boundary_uv, iterations=0
    )
    assert len(history) == 1
    assert_allclose(uv, disk.vertices[:, :2], rtol=0, atol=1e-12)


@pytest.mark.parametrize("iterations", [0, 3])
def test_map_keeps_the_boundary_and_flips_no_triangle(ellipsoid, iterations):
    v, f = ellipsoid
    edges, _ = unique_edges(f)
    disk, boundary_uv = _disk(v, f, initial_cut(v, f, edge_graph(v, edges), closed_genus0=True))
    uv, history = stretch_parameterize(
        disk.vertices, disk.faces, disk.loop, boundary_uv, iterations=iterations
    )
    assert 1 <= len(history) <= iterations + 1
    assert min(history) <= history[0]
    assert_array_equal(uv[disk.loop], boundary_uv)
    flat = flat_faces(disk.faces, disk.loop, boundary_uv)
    assert np.all(signed_uv_area(uv, disk.faces)[~flat] > 0)


def _stretch_by_rows(v, f, uv, flat):
    """Sander et al.'s stretch written row-wise over (m, 3) gathers: the reference."""
    q1, q2, q3 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    s1, s2, s3 = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    a, b, c = s1, s2, s3
    area = 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )
    area = np.where(flat | (area == 0), 1.0, area)[:, None]
    ds = (
        q1 * (s2[:, 1] - s3[:, 1])[:, None]
        + q2 * (s3[:, 1] - s1[:, 1])[:, None]
        + q3 * (s1[:, 1] - s2[:, 1])[:, None]
    ) / (2 * area)
    dt = (
        q1 * (s3[:, 0] - s2[:, 0])[:, None]
        + q2 * (s1[:, 0] - s3[:, 0])[:, None]
        + q3 * (s2[:, 0] - s1[:, 0])[:, None]
    ) / (2 * area)
    sigma = np.sqrt(0.5 * ((ds**2).sum(axis=1) + (dt**2).sum(axis=1)))
    sigma[flat] = 0.0
    return sigma


@pytest.mark.parametrize("chunk", [1 << 16, 5, 1])
def test_face_stretch_and_uv_area_are_the_row_wise_formulas_bit_for_bit(monkeypatch, chunk):
    monkeypatch.setattr(parameterize, "_CHUNK", chunk)
    rng = np.random.default_rng(chunk)
    v = rng.standard_normal((400, 3)) * 10.0 ** rng.uniform(-3, 3, 3)
    f = rng.integers(0, len(v), (1500, 3))
    uv = rng.uniform(0.0, 1.0, (len(v), 2))
    uv[:40] = 0.0  # faces with no UV area
    flat = rng.random(len(f)) < 0.1
    a, b, c = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    area = 0.5 * (
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )
    assert_array_equal(signed_uv_area(uv, f), area)
    got = parameterize._face_stretch(v, f, uv, flat)
    want = _stretch_by_rows(v, f, uv, flat)
    assert np.all(np.isfinite(want)) and np.any(want > 0)
    assert np.array_equal(got, want)


def test_grid_step_of_many_maps_is_the_two_ring_area_ratio(ellipsoid):
    v, f = ellipsoid
    edges, _ = unique_edges(f)
    graph = edge_graph(v, edges)
    disk, boundary_uv = _disk(v, f, initial_cut(v, f, graph, closed_genus0=True))
    flat = flat_faces(disk.faces, disk.loop, boundary_uv)
    step = GridStep(disk.vertices, disk.faces, disk.origin, len(v), graph, flat)
    # The reference: areas per face, summed on each vertex's faces, then over its two-ring.
    ring = (graph != 0).toarray().astype(float) + np.eye(len(v))
    ring2 = ring @ ring
    tri = disk.vertices[disk.faces]
    a3 = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    m = len(disk.faces)
    touch = np.zeros((len(v), m))
    for k in range(3):
        touch[disk.origin[disk.faces[:, k]], np.arange(m)] += 1.0
    rng = np.random.default_rng(0)
    for _ in range(3):  # one object, several maps: each the formula, and grid_step's bits
        uv = rng.uniform(0.1, 0.9, (len(disk.vertices), 2))
        uv[disk.loop] = boundary_uv
        auv = np.abs(signed_uv_area(uv, disk.faces))
        want = np.sqrt(
            ring2 @ touch @ np.where(flat, 0, a3) / (ring2 @ touch @ np.where(flat, 0, auv))
        )
        got = step(uv)
        assert_allclose(got, want, rtol=1e-12)
        assert_array_equal(
            got, grid_step(disk.vertices, disk.faces, uv, disk.origin, len(v), graph, flat)
        )


@pytest.mark.parametrize("chunk", [1 << 16, 7])
def test_laplacian_pattern_is_igls_cotmatrix_bit_for_bit(monkeypatch, chunk, spot_mesh, ellipsoid):
    # The off-diagonal entries of igl.cotmatrix, clamped: on meshes, on a triangulation of
    # random points (obtuse triangles, slivers) with a face of zero area; where an edge has
    # three faces or more, the same sums in another order.
    import igl
    from scipy.spatial import Delaunay

    monkeypatch.setattr(parameterize, "_CHUNK", chunk)
    rng = np.random.default_rng(chunk)
    flat = rng.uniform(0.0, 1.0, (300, 2))
    tri_f = Delaunay(flat).simplices.astype(np.int64)
    tri_v = np.column_stack([flat, rng.normal(0.0, 0.3, 300)]) * 10.0 ** rng.uniform(-3, 3)
    tri_v[tri_f[0, 2]] = 0.5 * (tri_v[tri_f[0, 0]] + tri_v[tri_f[0, 1]])
    fan = rng.integers(0, 200, (600, 3))  # many edges of three faces or more
    fan = fan[(fan[:, 0] != fan[:, 1]) & (fan[:, 1] != fan[:, 2]) & (fan[:, 0] != fan[:, 2])]
    cases = (spot_mesh, ellipsoid, (tri_v, tri_f), (rng.standard_normal((200, 3)), fan))
    for k, (v, f) in enumerate(cases):
        f = np.asarray(f, dtype=np.int64)
        lap = igl.cotmatrix(v, f).tocoo()
        off = lap.row != lap.col
        want_r, want_c, want_w = lap.row[off], lap.col[off], lap.data[off]
        want_w = np.maximum(want_w, 1e-3 * np.median(np.abs(want_w)))
        rows, cols, w = parameterize._laplacian_pattern(v, f)
        a, b = np.lexsort((want_c, want_r)), np.lexsort((cols, rows))
        assert_array_equal(rows[b], want_r[a])
        assert_array_equal(cols[b], want_c[a])
        if k < 3:
            assert np.array_equal(w[b], want_w[a], equal_nan=True)
        else:
            assert_allclose(w[b], want_w[a], rtol=1e-12, atol=0)
