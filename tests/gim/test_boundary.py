"""Tests for :mod:`meshwm.gim.boundary`: the boundary loop laid on the square's perimeter."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal

from meshwm.gim.boundary import boundary_chains, split_corners, unit_to_uv
from meshwm.gim.cut import area_centroid, cut_open, edge_graph, initial_cut
from meshwm.mesh.clean import unique_edges

N = 64


def _cut_ellipsoid(v, f):
    edges, _ = unique_edges(f)
    paths = initial_cut(v, f, edge_graph(v, edges), closed_genus0=True)
    radial = np.linalg.norm(v - area_centroid(v, f), axis=1)
    return cut_open(v, f, paths), radial


def test_unit_to_uv_walks_the_square_counter_clockwise():
    side = N - 1
    t = np.array([0, side, 2 * side, 3 * side, 4 * side, side / 2], dtype=float)
    assert unit_to_uv(t, N).tolist() == [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0], [0.5, 0]]


def test_one_cut_is_one_chain_on_both_halves_of_the_perimeter(ellipsoid):
    cut, radial = _cut_ellipsoid(*ellipsoid)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, N, radial)
    assert chains.chain_multiplicity.tolist() == [2]
    assert chains.run_chain == [0, 0] and chains.run_reversed == [False, True]
    assert chains.chain_steps.tolist() == [2 * (N - 1)]
    assert chains.run_unit.tolist() == [0, 2 * (N - 1), 4 * (N - 1)]
    assert np.all(np.diff(chains.unit) > 0) and chains.unit[0] == 0
    assert len(chains.chain_points[0]) == 2 * (N - 1) + 1
    keys = chains.chain_keys[0]
    assert keys[0][0] == keys[-1][0] == "v" and all(k[0] == "c" for k in keys[1:-1])


def test_split_corners_puts_a_vertex_on_every_corner(ellipsoid):
    cut, radial = _cut_ellipsoid(*ellipsoid)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, N, radial)
    disk = split_corners(cut.vertices, cut.faces, cut.origin, chains, N)
    side = N - 1
    assert set(disk.unit.tolist()) >= {0.0, side, 2.0 * side, 3.0 * side}
    assert np.all(np.diff(disk.unit) > 0)
    added = len(disk.vertices) - len(cut.vertices)
    assert len(disk.faces) == len(cut.faces) + added  # one face split per new vertex
    assert len(disk.origin) == len(disk.vertices)
    assert_array_equal(disk.vertices[: len(cut.vertices)], cut.vertices)


def test_a_disk_boundary_is_one_border_chain(flat_square):
    v, f = flat_square
    cut = cut_open(v, f, [])
    radial = np.linalg.norm(v - area_centroid(v, f), axis=1)
    chains = boundary_chains(cut.vertices, cut.faces, cut.origin, N, radial)
    assert chains.chain_multiplicity.tolist() == [1]
    assert chains.chain_steps.tolist() == [4 * (N - 1)]
    # The square's corners (equally far from the centroid) land on the square's corners.
    corners = np.isin(chains.unit, [0.0, N - 1, 2 * (N - 1), 3 * (N - 1)])
    found = {tuple(p) for p in v[chains.loop[corners], :2].tolist()}
    assert found == {(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)}
