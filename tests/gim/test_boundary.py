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


def test_the_boundary_loop_is_igls_on_cut_meshes(spot_mesh, kitten_mesh, plane_mesh, ellipsoid):
    # The same start and direction as igl.boundary_loop, on closed, open and holed meshes cut
    # open, with their faces and vertex numbers shuffled.
    from meshwm.gim.boundary import _igl_loop, _oriented_loop
    from meshwm.mesh.clean import clean_mesh

    rng = np.random.default_rng(0)
    for v, f in (spot_mesh, kitten_mesh, plane_mesh, ellipsoid):
        c = clean_mesh(v, f)
        edges, _ = unique_edges(c.faces)
        closed = (
            len(edges) * 2 == len(c.faces) * 3 and len(c.vertices) - len(edges) + len(c.faces) == 2
        )
        paths = initial_cut(
            c.vertices, c.faces, edge_graph(c.vertices, edges), closed_genus0=closed
        )
        for trial in range(3):
            perm = rng.permutation(len(c.vertices)) if trial else np.arange(len(c.vertices))
            rank = np.empty_like(perm)
            rank[perm] = np.arange(len(perm))
            cv, cf = c.vertices[perm], rank[c.faces][rng.permutation(len(c.faces))]
            cut = cut_open(cv, cf, [rank[p] for p in paths])
            loop = _oriented_loop(cut.faces)
            assert len(loop) >= 3
            assert_array_equal(loop, _igl_loop(cut.faces))


def test_a_border_of_two_loops_asks_igl_for_the_longest(flat_square):
    # Two separate squares, the second larger: not one loop, so igl's longest loop.
    from meshwm.gim.boundary import _oriented_loop

    v, f = flat_square
    f2 = np.concatenate([f, f + len(v)])
    f2 = np.concatenate([f2, [[len(v) * 2, len(v) * 2 + 1, len(v) * 2 + 2]]])
    loop = _oriented_loop(f2)
    assert len(loop) == len(_oriented_loop(f))
