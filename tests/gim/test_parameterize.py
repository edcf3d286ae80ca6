"""Tests for :mod:`meshwm.gim.parameterize`: the map of the disk onto the unit square."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.gim.boundary import boundary_chains, split_corners, unit_to_uv
from meshwm.gim.cut import area_centroid, cut_open, edge_graph, initial_cut
from meshwm.gim.parameterize import flat_faces, signed_uv_area, stretch_parameterize
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
