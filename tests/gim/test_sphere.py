"""Tests for :mod:`meshwm.gim.sphere`: the point set's pose and its spherical image."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.attacks import apply_attack
from meshwm.errors import MeshError
from meshwm.gim.sphere import (
    octahedral_directions,
    point_count,
    point_poses,
    point_set,
    sphere_sampling,
)
from meshwm.metrics import bounding_box_diagonal


def _image(v, f, n=64, k=0):
    points = point_set(v, f).points
    return sphere_sampling(points, point_poses(points)[k], n).image


def _random_similarity(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    return q, 10.0 ** rng.uniform(-2, 2), rng.uniform(-100, 100, 3)


def test_the_point_set_ignores_order_duplicates_and_unused_vertices(spot_mesh):
    v, f = spot_mesh
    rng = np.random.default_rng(0)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    shuffled = point_set(v[perm], inverse[f][rng.permutation(len(f))])
    base = point_set(v, f)
    assert_array_equal(shuffled.points, base.points)
    # A soup (three vertices per face) and an unused vertex give the same points.
    soup = point_set(np.vstack([v[f.ravel()], [[9.0, 9, 9]]]), np.arange(f.size).reshape(-1, 3))
    assert_array_equal(soup.points, base.points)
    assert soup.of_vertex[-1] == -1
    assert_array_equal(soup.points[soup.of_vertex[:-1]], v[f.ravel()])


@pytest.mark.parametrize("seed", range(4))
def test_point_count_is_the_point_sets_size(spot_mesh, seed):
    v, f = spot_mesh
    rng = np.random.default_rng(seed)
    # Quantised copies coincide, a -0.0 is the +0.0 point, unused vertices are not counted.
    q = np.round(v * 10.0 ** rng.uniform(0.5, 2)) / 10.0 ** rng.uniform(0.5, 2)
    q[rng.integers(0, len(q), 50), rng.integers(0, 3)] = -0.0
    q = np.vstack([q, rng.normal(size=(7, 3))])
    faces = f[rng.permutation(len(f))[: len(f) // (seed + 1)]]
    assert point_count(q, faces) == len(point_set(q, faces).points)
    assert point_count(q, faces) < len(np.unique(faces))  # some points did coincide


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        ("flip_edges", {"count": 1000}),
        ("retriangulate", {}),
        ("split_seams", {}),
        ("merge_load", {}),
        ("reorder", {}),
    ],
)
def test_connectivity_edits_leave_the_image_exactly_as_it_was(spot_mesh, attack, options):
    v, f = spot_mesh
    av, af = apply_attack(attack, v, f, seed=11, **options)
    assert_array_equal(_image(av, af), _image(v, f))


def test_the_image_is_the_same_under_random_similarities(spot_mesh):
    v, f = spot_mesh
    base = _image(v, f, n=128)
    scale0 = point_poses(point_set(v, f).points)[0].scale
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, scale, shift = _random_similarity(rng)
        again = _image(scale * v @ q.T + shift, f, n=128)
        # Radii are in units of the RMS radius: the same numbers, to rounding.
        assert np.abs(again - base).max() < 1e-9 * bounding_box_diagonal(v) / scale0


def test_radial_moves_leave_the_sampling_matrix_and_move_the_image_linearly(kitten_mesh):
    v, f = kitten_mesh
    points = point_set(v, f).points
    pose = point_poses(points)[0]
    s = sphere_sampling(points, pose, 64)
    rng = np.random.default_rng(1)
    t = rng.normal(size=len(points)) * 1e-4
    moved = points + (t * pose.scale)[:, None] * s.directions
    again = sphere_sampling(moved, pose, 64)
    # The same neighbours and weights (to the rounding of the recomputed directions).
    assert_array_equal(again.matrix.indices, s.matrix.indices)
    assert_allclose(again.matrix.data, s.matrix.data, rtol=0, atol=1e-9)
    assert_allclose(again.radii, s.radii + t, rtol=0, atol=1e-10)
    assert_allclose(again.image, s.image + (s.matrix @ t).reshape(64, 64), rtol=0, atol=1e-9)
    assert_allclose(np.asarray(s.matrix.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)


def test_a_mirror_symmetric_shape_offers_both_signs():
    rng = np.random.default_rng(2)
    half = rng.normal(size=(400, 3)) * [3.0, 2.0, 1.0]
    half[:, 0] = np.abs(half[:, 0]) ** 1.5  # lopsided along x: its sign is its own
    points = np.vstack([half, half * [1.0, -1.0, 1.0]])  # mirrored in y: no sign there
    poses = point_poses(points)
    assert len(poses) == 2
    a, b = (p.rotation for p in poses)
    assert_allclose(a[:, 0], b[:, 0], atol=1e-12)
    assert_allclose(a[:, 1], -b[:, 1], atol=1e-12)
    for p in poses:
        assert_allclose(p.rotation.T @ p.rotation, np.eye(3), atol=1e-12)
        assert np.linalg.det(p.rotation) == pytest.approx(1.0)


def test_a_square_plate_is_oriented_by_its_fourth_moment():
    g = np.linspace(-1, 1, 21)
    x, y = np.meshgrid(g, g)
    top = np.stack([x.ravel(), y.ravel(), 0.05 + 0.01 * x.ravel()], axis=1)
    points = np.vstack([top, top * [1, 1, -1]])  # the two moments in the plane are tied
    poses = point_poses(points)
    assert len(poses) >= 4  # the four quarter turns (signs may add more)
    # Every turn lines an axis up with the square's sides (or its diagonals), the same way
    # whatever the square's turn in the input.
    turn = np.array([[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]])
    again = point_poses(points @ turn.T)
    assert len(again) == len(poses)
    first = [p.forward(points) for p in poses]
    second = [p.forward(points @ turn.T) for p in again]
    for a in first:
        assert any(np.abs(a - b).max() < 1e-9 for b in second)


def test_flat_and_tiny_point_sets_have_no_pose():
    with pytest.raises(MeshError, match="at least 4"):
        point_poses(np.eye(3))
    flat = np.random.default_rng(0).normal(size=(50, 3)) * [1.0, 1.0, 0.0]
    with pytest.raises(MeshError, match="plane"):
        point_poses(flat)


def test_octahedral_directions_cover_the_sphere_evenly():
    d = octahedral_directions(64)
    assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    assert len(np.unique(np.round(d, 12), axis=0)) == len(d)
    # Each octant holds an eighth of the pixels (those on the octahedron's edges aside).
    octant = (d > 0) @ np.array([1, 2, 4])
    assert_allclose(np.bincount(octant, minlength=8), len(d) / 8, rtol=0.05)


def test_the_image_is_continuous_where_a_pixel_s_last_neighbour_changes():
    # Two layers of directions, radii 1 and 0.4: a shape that is not star-shaped around its
    # centre.  Slide a pixel's 9th nearest direction (its radius kept) to just outside its
    # 8th, then to just inside: it becomes a neighbour and the 8th leaves.  A weight that did
    # not vanish at the last neighbour jumps the pixel by ~0.04 (the two layers' radii apart);
    # the image must not jump.
    rng = np.random.default_rng(11)
    unit = rng.normal(size=(4000, 3))
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    points = unit * np.where(np.arange(4000) % 2 == 0, 1.0, 0.4)[:, None]
    pose = point_poses(points)[0]
    n = 32
    canonical = pose.forward(points)
    radius = np.linalg.norm(canonical, axis=1)
    directions = canonical / radius[:, None]
    grid = octahedral_directions(n)

    def slid(pixel, point, distance):
        # ``point`` slid along its great circle towards the pixel to chord ``distance``.
        lo, hi = 0.0, 1.0
        for _ in range(80):
            t = 0.5 * (lo + hi)
            d = directions[point] + t * (grid[pixel] - directions[point])
            if np.linalg.norm(d / np.linalg.norm(d) - grid[pixel]) > distance:
                lo = t
            else:
                hi = t
        moved = canonical.copy()
        d = directions[point] + hi * (grid[pixel] - directions[point])
        moved[point] = d / np.linalg.norm(d) * radius[point]
        return sphere_sampling(pose.inverse(moved), pose, n).image.ravel()[pixel]

    checked = 0
    for pixel in rng.permutation(len(grid)):
        chord = np.linalg.norm(directions - grid[pixel], axis=1)
        order = np.argsort(chord)
        eighth, ninth = order[7], order[8]
        if abs(radius[eighth] - radius[ninth]) < 0.3 or chord[eighth] - chord[order[6]] < 1e-5:
            continue  # the same layer (no jump to see), or a tie in front of the 8th
        outside = slid(pixel, ninth, chord[eighth] + 1e-8)
        inside = slid(pixel, ninth, chord[eighth] - 1e-8)
        assert abs(inside - outside) < 1e-5
        checked += 1
        if checked == 20:
            break
    assert checked == 20
