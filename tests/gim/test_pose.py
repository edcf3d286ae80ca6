"""Tests for :mod:`meshwm.gim.pose`: the canonical pose the remesh is computed in."""

from __future__ import annotations

import numpy as np

from meshwm.gim.pose import REMESH_SNAP, SNAP, canonical_mesh, canonical_pose
from meshwm.gim.remesh import _tied, mesh_to_geometry_image
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


def _shuffled(rng, v, f):
    """The mesh with its vertices, its faces and each face's corners in a random order."""
    perm = rng.permutation(len(v))
    back = np.argsort(perm)
    g = back[f][rng.permutation(len(f))]
    g = np.take_along_axis(g, (rng.integers(0, 3, len(g))[:, None] + np.arange(3)) % 3, axis=1)
    return v[perm], g


def test_the_canonical_mesh_is_the_same_arrays_in_any_pose_and_order(kitten_mesh, spot_mesh):
    # What the remesh runs on: bit for bit the same vertices and faces whatever the pose,
    # scale, translation and element order (12 random similarities of each mesh, shuffled).
    for v, f in (kitten_mesh, spot_mesh):
        base = canonical_mesh(v, f)
        assert np.array_equal(base.vertices, np.round(base.vertices / REMESH_SNAP) * REMESH_SNAP)
        np.testing.assert_array_equal(base.pose.snap(v, REMESH_SNAP)[base.order], base.vertices)
        rng = np.random.default_rng(21)
        for _ in range(12):
            moved, _ = _moved(rng, v)
            again = canonical_mesh(*_shuffled(rng, moved, f))
            np.testing.assert_array_equal(again.vertices, base.vertices)
            np.testing.assert_array_equal(again.faces, base.faces)


def test_the_canonical_mesh_keeps_every_face_and_its_winding(spot_mesh):
    v, f = spot_mesh
    c = canonical_mesh(v, f)
    assert np.all(c.faces[:, 0] < c.faces[:, 1]) and np.all(c.faces[:, 0] < c.faces[:, 2])
    back = c.order[c.faces]  # input vertices
    as_cycles = {tuple(np.roll(t, -int(np.argmin(t)))) for t in f.tolist()}
    assert {tuple(np.roll(t, -int(np.argmin(t)))) for t in back.tolist()} == as_cycles


def test_detail_below_the_snap_keeps_the_fine_grid():
    # Two vertices 1e-9 of the radius apart would coincide on the remesh's grid: the fine
    # grid is used instead, and they stay apart.
    v = np.array([[0.0, 0, 0], [4, 0, 0], [0, 1, 0], [0, 0, 0.5], [3e-9, 5e-9, 7e-9]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 4], [4, 3, 2], [0, 4, 2], [1, 2, 3]])
    c = canonical_mesh(v, f)
    assert len(np.unique(c.vertices, axis=0)) == 5
    np.testing.assert_array_equal(c.vertices, c.pose.snap(v, SNAP)[c.order])


def _mirrored_blob() -> tuple[np.ndarray, np.ndarray]:
    """A bumpy sphere that the mirror x -> -x maps onto itself, vertex onto vertex, and no
    rotation does: its third moment along x is zero."""
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=3)
    v = np.asarray(ico.vertices, dtype=np.float64)
    x, y, z = v.T
    r = 1 + 0.25 * y + 0.15 * z * z + 0.2 * y * z + 0.1 * x * x + 0.05 * y**3
    return v * r[:, None], np.asarray(ico.faces, dtype=np.int64)


def test_only_a_shape_whose_distances_tie_takes_the_canonical_copy(kitten_mesh, spot_mesh):
    from meshwm.apps.bench.synthetic import make

    for (v, f), tied in ((kitten_mesh, False), (spot_mesh, False), (make("genus8"), True)):
        assert _tied(canonical_pose(v, f).forward(v)) is tied
    v, f = _mirrored_blob()
    assert _tied(canonical_pose(v, f).forward(v))


def test_a_mirror_symmetric_shape_has_one_canonical_copy_and_one_grid_image():
    # Its third moment along the mirror's normal is zero, so rounding picked that axis's sign
    # and the frame was the shape turned half about another axis, which is not a symmetry
    # (4 of 8 similarities gave another grid image); oriented by its two strongest third
    # moments, every pose gives the same arrays and the same image.
    v, f = _mirrored_blob()
    base = canonical_mesh(v, f)
    image = mesh_to_geometry_image(v, f, size=64).gim
    diag = bounding_box_diagonal(v)
    rng = np.random.default_rng(9)
    for _ in range(8):
        moved, (q, scale, shift) = _moved(rng, v)
        w, g = _shuffled(rng, moved, f)
        again = canonical_mesh(w, g)
        np.testing.assert_array_equal(again.vertices, base.vertices)
        np.testing.assert_array_equal(again.faces, base.faces)
        got = ((mesh_to_geometry_image(w, g, size=64).gim - shift) / scale) @ q
        assert np.abs(got - image).max() < 1e-9 * diag
