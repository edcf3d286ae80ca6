"""Tests for :mod:`meshwm.gim.sample`: the map sampled on the N×N grid, and the weld map."""

from __future__ import annotations

import numpy as np
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
