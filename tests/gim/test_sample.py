"""Tests for :mod:`meshwm.gim.sample`: the map sampled on the N×N grid, and the weld map."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.gim.boundary import boundary_chains, split_corners, unit_to_uv
from meshwm.gim.cut import area_centroid, cut_open
from meshwm.gim.parameterize import stretch_parameterize
from meshwm.gim.sample import sample_geometry_image

N = 64


def test_a_flat_square_samples_the_grid_points_and_welds_nothing(flat_square):
    v, f = flat_square
    cut = cut_open(v, f, [])
    radial = np.linalg.norm(v - area_centroid(v, f), axis=1)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, N, radial)
    disk = split_corners(cut.vertices, cut.faces, cut.origin, chains, N)
    boundary_uv = unit_to_uv(disk.unit, N)
    uv, _ = stretch_parameterize(disk.vertices, disk.faces, disk.loop, boundary_uv, iterations=0)
    gim, weld = sample_geometry_image(disk.vertices, disk.faces, uv, chains, N)
    i, j = np.meshgrid(np.arange(N), np.arange(N), indexing="ij")
    expected = np.stack([j / (N - 1), i / (N - 1), np.zeros((N, N))], axis=-1)
    assert gim.shape == (N, N, 3) and gim.dtype == np.float64
    assert_allclose(gim, expected, rtol=0, atol=1e-12)
    assert_array_equal(weld, np.arange(N * N).reshape(N, N))  # a disk has no seam


@pytest.mark.parametrize("seed", range(6))
def test_closest_faces_are_the_whole_trees_or_closer(seed):
    # Many small triangles, most far from every grid point; part of the square uncovered
    # (its points ask the whole tree); the closest points of a tree over all faces, or closer.
    import igl
    from scipy.spatial import Delaunay

    from meshwm.gim import sample

    rng = np.random.default_rng(seed)
    low = 0.03 if seed % 2 else 0.0  # odd seeds: the first row and column uncovered
    uv = rng.uniform(low, 1.0, size=(4000, 2))
    uv[:4] = [[low, low], [1, low], [low, 1], [1, 1]]
    faces = Delaunay(uv).simplices.astype(np.int64)
    n = 33
    g = np.arange(n) / (n - 1)
    uu, vv = np.meshgrid(g, g)
    points = np.stack([uu.ravel(), vv.ravel(), np.zeros(n * n)], axis=1)
    face_id, closest = sample._closest_faces(uv, faces, points, n)
    uv3 = np.column_stack([uv, np.zeros(len(uv))])
    tree = igl.AABB()
    tree.init(uv3, faces)
    sq_all, id_all, closest_all = tree.squared_distance(uv3, faces, points)
    # Never farther than the whole tree's closest point (which on the hull's slivers is off
    # by up to 3e-7: igl's point-triangle distance; a point the scan finds in its triangle
    # is its own closest point, in exact arithmetic too: test_sampling.py).
    d = np.linalg.norm(closest[:, :2] - points[:, :2], axis=1)
    assert np.all(d**2 <= np.asarray(sq_all) * (1 + 1e-12) + 1e-24)
    off = np.asarray(sq_all) > 1e-12  # off the domain: the tree's own answer
    assert_allclose(closest[off], closest_all[off], rtol=0, atol=1e-15)
    assert off.any() == bool(seed % 2)
    # The face found holds the closest point.
    uvt = uv[faces[face_id]]
    bary = np.linalg.solve(
        np.stack([uvt[:, 1] - uvt[:, 0], uvt[:, 2] - uvt[:, 0]], axis=2),
        (closest[:, :2] - uvt[:, 0])[:, :, None],
    )[:, :, 0]
    assert np.all(bary >= -1e-9) and np.all(bary.sum(axis=1) <= 1 + 1e-9)
    same = np.asarray(id_all) == face_id
    assert same.mean() > 0.9
