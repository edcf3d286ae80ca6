"""Tests for :mod:`meshwm.attacks.seams`: UV-seam splits, STL re-welding, trimesh's merging load.

On the bundled spot, kitten and plane_holes meshes; the dev mesh cow (with its one pair of
coincident vertices) when ../shared/meshes is next to the repository.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from _attack_checks import _same_mesh
from numpy.testing import assert_array_equal

from meshwm.attacks.seams import (
    material_patches,
    merge_load,
    split_seam_paths,
    split_seams,
    weld_by_position,
    weld_stl,
)
from meshwm.attacks.transforms import round_trip
from meshwm.mesh.clean import edge_topology_counts, euler_characteristic
from meshwm.mesh.io import read_mesh

COW = Path(__file__).resolve().parents[3] / "shared" / "meshes" / "cow.ply"


def _boundary_vertices(faces) -> set[int]:
    f = np.asarray(faces)
    directed = np.stack([f, np.roll(f, -1, axis=1)], axis=2).reshape(-1, 2)
    edges, count = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    return set(edges[count == 1].ravel().tolist())


# --- split_seams -----------------------------------------------------------------------------


@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh", "plane_mesh"])
def test_split_then_weld_gives_back_the_mesh(request, fixture):
    v, f = request.getfixturevalue(fixture)
    v2, f2 = split_seams(v, f, seed=1, paths=4, length=15)
    assert len(v2) > len(v)
    w, g = weld_by_position(v2, f2)
    assert_array_equal(w, v)
    assert_array_equal(g, f)


@pytest.mark.parametrize(("paths", "length"), [(1, 2), (3, 20), (5, 40)])
def test_seams_open_the_mesh_along_their_paths(spot_mesh, paths, length):
    v, f = spot_mesh
    result = split_seam_paths(v, f, seed=2, paths=paths, length=length)
    assert len(result.paths) == paths
    assert all(len(path) == length + 1 for path in result.paths)
    copies = paths * (length - 1)
    assert len(result.vertices) == len(v) + copies and len(result.source) == copies
    assert_array_equal(result.vertices[: len(v)], v)
    assert_array_equal(result.vertices[len(v) :], v[result.source])  # same positions exactly
    assert result.faces.shape == f.shape
    n_edges, n_boundary, n_nonmanifold = edge_topology_counts(result.faces)
    assert n_edges == edge_topology_counts(f)[0] + paths * length
    assert n_boundary == 2 * paths * length and n_nonmanifold == 0
    # every seam is a slit: one boundary loop each, Euler characteristic down by one per seam
    assert euler_characteristic(len(result.vertices), result.faces) == 2 - paths
    inner = np.concatenate([path[1:-1] for path in result.paths])
    assert_array_equal(np.sort(result.source), np.sort(inner))


def test_seam_copies_take_the_faces_on_one_side(spot_mesh):
    v, f = spot_mesh
    result = split_seam_paths(v, f, seed=3, paths=1, length=10)
    n = len(v)
    for original, copy in zip(result.source.tolist(), range(n, n + 9), strict=True):
        with_original = np.any(result.faces == original, axis=1)
        with_copy = np.any(result.faces == copy, axis=1)
        assert with_original.any() and with_copy.any()
        assert not np.any(with_original & with_copy)
        assert (with_original | with_copy).sum() == np.any(f == original, axis=1).sum()


def test_seams_avoid_boundaries(plane_mesh):
    v, f = plane_mesh
    boundary = _boundary_vertices(f)
    result = split_seam_paths(v, f, seed=4, paths=5, length=10)
    assert len(result.paths) == 5
    assert not set(np.concatenate(result.paths).tolist()) & boundary


def test_later_seams_do_not_touch_earlier_ones(kitten_mesh):
    result = split_seam_paths(*kitten_mesh, seed=5, paths=8, length=25)
    inner = np.concatenate([path[1:-1] for path in result.paths])
    assert len(np.unique(inner)) == len(inner)


def test_too_long_a_seam_is_not_cut():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    result = split_seam_paths(v, f, paths=2, length=5)
    assert result.paths == [] and result.source.shape == (0,)
    assert_array_equal(result.vertices, v)
    assert_array_equal(result.faces, f)


def test_seams_are_seeded(spot_mesh):
    v, f = spot_mesh
    a, b = split_seams(v, f, seed=6), split_seams(v, f, seed=6)
    assert_array_equal(a[0], b[0])
    assert_array_equal(a[1], b[1])
    assert not np.array_equal(split_seams(v, f, seed=7)[1], a[1])


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"paths": 0}, r"split_seams: paths must be an integer >= 1, got 0"),
        ({"length": 1}, r"split_seams: length must be an integer >= 2, got 1"),
    ],
)
def test_bad_seam_options_raise(spot_mesh, options, match):
    with pytest.raises(ValueError, match=match):
        split_seams(*spot_mesh, **options)


# --- welding and loading ---------------------------------------------------------------------


def test_weld_stl_re_welds_the_soup(spot_mesh):
    v, f = spot_mesh
    soup_v, _ = round_trip(v, f, suffix=".stl")
    assert len(soup_v) == 3 * len(f)
    w, g = weld_stl(v, f)
    assert len(w) == len(v) and g.shape == f.shape
    rounded = v.astype(np.float32).astype(np.float64)
    assert _same_mesh(w, g, rounded, f)


def test_weld_by_position_merges_signed_zeros_and_keeps_first_order():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-0.0, 0.0, 0.0]])
    w, g = weld_by_position(v, [[3, 1, 2], [0, 2, 1]])
    assert w.tolist() == [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    assert g.tolist() == [[0, 1, 2], [0, 2, 1]]


def test_merge_load_is_trimesh_default_processing(spot_mesh):
    v, f = spot_mesh
    dup_v = np.vstack([v, v[:1]])  # vertex 0 twice, one face using the copy
    dup_f = f.copy()
    k = int(np.flatnonzero(np.any(f == 0, axis=1))[0])
    dup_f[k][dup_f[k] == 0] = len(v)
    w, g = merge_load(dup_v, dup_f)
    assert len(w) == len(v) and g.shape == f.shape
    assert _same_mesh(w, g, v, f)


@pytest.mark.skipif(not COW.is_file(), reason="the dev meshes are not next to the repository")
def test_merge_load_merges_cow_duplicate_pair():
    v, f = read_mesh(COW)
    w, g = merge_load(v, f)
    assert len(w) == len(v) - 1 and g.shape == f.shape
    loaded = trimesh.load(COW)
    assert_array_equal(w, loaded.vertices)
    assert_array_equal(g, loaded.faces)


@pytest.mark.parametrize("count", [1, 2, 7])
def test_material_patches_are_connected_and_cover_the_mesh(spot_mesh, count):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    _, f = spot_mesh
    for seed in range(3):
        patch = material_patches(f, count=count, seed=seed)
        assert patch.shape == (len(f),) and np.bincount(patch).tolist().count(0) == 0
        assert len(np.bincount(patch)) == count
        for p in range(count):
            faces = f[patch == p]
            mesh = trimesh.Trimesh(np.zeros((f.max() + 1, 3)), faces, process=False)
            adjacency = mesh.face_adjacency
            ones = np.ones(len(adjacency))
            graph = coo_matrix((ones, (adjacency[:, 0], adjacency[:, 1])), shape=(len(faces),) * 2)
            assert connected_components(graph, directed=False)[0] == 1
    assert_array_equal(material_patches(f, count=5, seed=3), material_patches(f, count=5, seed=3))
    assert not np.array_equal(material_patches(f, count=5, seed=3), material_patches(f, count=5))


@pytest.mark.parametrize("count", [0, 2.5, 10**9])
def test_bad_patch_counts_raise(spot_mesh, count):
    with pytest.raises(ValueError, match="count must be an integer"):
        material_patches(spot_mesh[1], count=count)
