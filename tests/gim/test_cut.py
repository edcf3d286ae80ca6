"""Tests for :mod:`meshwm.gim.cut`: cutting a mesh open into a disk, and extending the cut."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components

from meshwm.errors import MeshError
from meshwm.gim.cut import (
    area_centroid,
    count_loops,
    cut_open,
    edge_graph,
    extend_cut,
    initial_cut,
    path_edges,
)
from meshwm.mesh.clean import clean_mesh, edge_topology_counts, unique_edges


def _graph_and_radial(vertices, faces):
    edges, _ = unique_edges(faces)
    radial = np.linalg.norm(vertices - area_centroid(vertices, faces), axis=1)
    return edge_graph(vertices, edges), radial


def test_closed_genus0_mesh_is_cut_along_one_path_into_a_disk(ellipsoid):
    v, f = ellipsoid
    graph, _ = _graph_and_radial(v, f)
    paths = initial_cut(v, f, graph, closed_genus0=True)
    assert len(paths) == 1
    path = paths[0]
    assert len(np.unique(path)) == len(path) >= 3  # a simple path
    cut = cut_open(v, f, paths)
    chi = len(cut.vertices) - edge_topology_counts(cut.faces)[0] + len(cut.faces)
    assert chi == 1
    # Inner path vertices are split in two, its ends are not.
    assert len(cut.vertices) == len(v) + len(path) - 2
    assert np.array_equal(cut.vertices, v[cut.origin])


def test_the_first_cut_is_the_same_with_the_callers_radial_distances(ellipsoid, spot_mesh):
    # The remesh hands its surface's distances to the centroid to the first cut, which would
    # compute the same numbers: the same path; other distances pick another one.
    for v, f in (ellipsoid, spot_mesh):
        graph, radial = _graph_and_radial(v, f)
        own = initial_cut(v, f, graph, closed_genus0=True)
        given = initial_cut(v, f, graph, closed_genus0=True, radial=radial)
        np.testing.assert_array_equal(given[0], own[0])
        other = initial_cut(v, f, graph, closed_genus0=True, radial=-radial)
        assert not np.array_equal(other[0], own[0])


def test_a_torus_is_cut_into_a_disk_by_cut_to_disk(kitten_mesh):
    clean = clean_mesh(*kitten_mesh)
    v, f = clean.vertices, clean.faces
    graph, _ = _graph_and_radial(v, f)
    paths = initial_cut(v, f, graph, closed_genus0=False)
    assert len(paths) >= 2  # genus 1: two loops at least
    cut = cut_open(v, f, paths)
    assert len(cut.vertices) - edge_topology_counts(cut.faces)[0] + len(cut.faces) == 1


def test_an_uncut_closed_mesh_is_not_a_disk(ellipsoid):
    with pytest.raises(MeshError, match="could not cut the mesh open into a disk"):
        cut_open(*ellipsoid, [])


def test_count_loops(flat_square, ellipsoid):
    for (v, f), loops in ((flat_square, 1), (ellipsoid, 0)):
        edges, inverse = unique_edges(f)
        border = np.bincount(inverse, minlength=len(edges)) == 1
        assert count_loops(len(v), edges, border) == loops


def test_path_edges():
    paths = [np.array([0, 1, 2]), np.array([5]), np.array([3, 4])]
    assert path_edges(paths).tolist() == [[0, 1], [1, 2], [3, 4]]
    assert path_edges([]).shape == (0, 2)


def test_extend_cut_adds_one_path_per_region_back_to_the_cut(ellipsoid):
    v, f = ellipsoid
    graph, radial = _graph_and_radial(v, f)
    paths = initial_cut(v, f, graph, closed_genus0=True)
    on_cut = np.zeros(len(v), dtype=bool)
    on_cut[paths[0]] = True
    undersampled = np.abs(v[:, 1]) > 0.8  # two caps, either side of the cut
    _, region = connected_components(graph[undersampled][:, undersampled], directed=False)
    more = extend_cut(paths, graph, on_cut=on_cut, undersampled=undersampled, radial=radial)
    assert len(more) == len(paths) + len(np.unique(region))
    assert all(a is b for a, b in zip(paths, more, strict=False))  # the old paths are kept
    for path in more[len(paths) :]:
        assert undersampled[path[0]] and on_cut[path[-1]]
        assert np.all(graph[path[:-1], path[1:]] > 0)  # a path along edges


@pytest.mark.parametrize("chunk", [1 << 20, 1000, 1])
def test_area_centroid_gives_the_bits_of_the_plain_formula(spot_mesh, chunk, monkeypatch):
    """The centroid decides cuts that marks already embedded rely on: the column-wise form,
    in chunks of faces or not, must keep the plain formula's bits, under any similarity."""
    from meshwm.gim import cut

    monkeypatch.setattr(cut, "_CENTROID_CHUNK", chunk)
    v0, f = spot_mesh
    rng = np.random.default_rng(3)
    for _ in range(20 if chunk > 1 else 2):
        v = v0 * rng.uniform(0.01, 100) + rng.uniform(-100, 100, size=3)
        tri = v[f]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        plain = (area[:, None] * tri.mean(axis=1)).sum(axis=0) / area.sum()
        assert np.array_equal(area_centroid(v, f), plain)


def test_area_centroid_of_faces_without_area_is_their_corners_mean():
    # A smoothed triangle soup's faces collapse to points: no NaN (0 / 0), and a similarity
    # moves the centroid with the mesh.
    rng = np.random.default_rng(4)
    points = rng.random((30, 1, 3))
    v = np.repeat(points, 3, axis=1).reshape(-1, 3)  # every face three copies of one point
    f = np.arange(90).reshape(-1, 3)
    c = area_centroid(v, f)
    assert np.allclose(c, points.mean(axis=(0, 1)))
    scale, shift = 37.5, np.array([3.0, -80.0, 11.0])
    assert np.allclose(area_centroid(v * scale + shift, f), c * scale + shift)
    assert np.array_equal(area_centroid(v, f[:0]), np.zeros(3))


@pytest.mark.parametrize("seed", range(4))
def test_argmax_stable_is_the_last_of_a_lexsort(seed):
    # Many exact ties in both keys, with NaN, inf and -0.0 among them: lexsort's last index.
    from meshwm.gim.cut import argmax_stable

    rng = np.random.default_rng(seed)
    for _ in range(500):
        n = int(rng.integers(1, 30))
        keys = rng.integers(0, 4, (2, n)).astype(float)
        r = rng.random((2, n))
        keys[r < 0.05] = np.nan
        keys[(r >= 0.05) & (r < 0.1)] = np.inf
        keys[(r >= 0.1) & (r < 0.2)] = -0.0
        values, tiebreak = keys
        assert argmax_stable(values, tiebreak) == int(np.lexsort((tiebreak, values))[-1])


@pytest.mark.parametrize("seed", range(4))
def test_cut_flags_mark_the_face_edges_on_a_path(seed):
    from meshwm.gim.cut import _cut_flags

    rng = np.random.default_rng(seed)
    faces = rng.integers(0, 60, (400, 3))
    paths = [rng.integers(0, 60, int(rng.integers(2, 12))) for _ in range(3)]
    on = {frozenset(e) for p in paths for e in zip(p[:-1].tolist(), p[1:].tolist(), strict=True)}
    want = np.array(
        [[frozenset((f[k], f[(k + 1) % 3])) in on for k in range(3)] for f in faces.tolist()]
    )
    got = _cut_flags(faces, paths)
    assert got.any() and np.array_equal(got, want)
    assert not _cut_flags(faces, []).any()


def test_edge_count_of_oriented_meshes_by_half_edges(spot_mesh, kitten_mesh, plane_mesh):
    # Cleaned meshes, cut open or not, by half-edges; a face against its neighbours (its edges
    # run twice the same way) counted: the unique edges' number each time.
    from meshwm.gim.cut import _edge_count

    for v, f in (spot_mesh, kitten_mesh, plane_mesh):
        c = clean_mesh(v, f)
        edges, _ = unique_edges(c.faces)
        assert _edge_count(c.faces) == len(edges)
        closed = 2 * len(edges) == 3 * len(c.faces)
        genus0 = closed and len(c.vertices) - len(edges) + len(c.faces) == 2
        graph = edge_graph(c.vertices, edges)
        paths = initial_cut(c.vertices, c.faces, graph, closed_genus0=genus0)
        cut = cut_open(c.vertices, c.faces, paths)
        assert _edge_count(cut.faces) == edge_topology_counts(cut.faces)[0]
        flipped = c.faces.copy()
        flipped[0] = flipped[0, ::-1]
        assert _edge_count(flipped) == edge_topology_counts(flipped)[0]
