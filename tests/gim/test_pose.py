"""Tests for :mod:`meshwm.gim.pose`: the canonical pose the remesh is computed in."""

from __future__ import annotations

import numpy as np

from meshwm.gim.pose import canonical_pose
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.metrics import bounding_box_diagonal


def _moved(rng, v):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    scale, shift = 10.0 ** rng.uniform(-2, 2), rng.uniform(-100, 100, 3)
    return scale * v @ q.T + shift, (q, scale, shift)


def test_canonical_coordinates_do_not_depend_on_the_pose(kitten_mesh):
    v, f = kitten_mesh
    base = canonical_pose(v, f).forward(v)
    rng = np.random.default_rng(1)
    for _ in range(10):
        moved, _ = _moved(rng, v)
        again = canonical_pose(moved, f).forward(moved)
        # Equal to the digits a pose far from the origin leaves (translation 100, scale 0.01).
        assert np.abs(again - base).max() <= 1e-9


def test_the_pose_is_a_similarity_that_round_trips(spot_mesh):
    v, f = spot_mesh
    pose = canonical_pose(v, f)
    assert np.allclose(pose.rotation.T @ pose.rotation, np.eye(3))
    assert np.linalg.det(pose.rotation) > 0
    back = pose.inverse(pose.forward(v))
    assert np.abs(back - v).max() < 1e-9 * bounding_box_diagonal(v)


def test_the_remesh_of_a_moved_mesh_is_the_moved_remesh(spot_mesh):
    v, f = spot_mesh
    base = mesh_to_geometry_image(v, f, size=64).gim
    rng = np.random.default_rng(7)
    for _ in range(3):
        moved, (q, scale, shift) = _moved(rng, v)
        got = mesh_to_geometry_image(moved, f, size=64).gim
        back = ((got - shift) / scale) @ q
        assert np.abs(back - base).max() < 1e-9 * bounding_box_diagonal(v)
