"""Tests for :mod:`meshwm.mesh.zip`: seams whose copies drifted apart, zipped again."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from meshwm.attacks import apply_attack
from meshwm.mesh.zip import ZIP_TOLERANCE, zip_borders


def _faces_as_input(v_in, zipped):
    """The zipped faces in the input's vertex ids (each zipped vertex's nearest input vertex),
    as a sorted set of sorted rows, and how many distinct input vertices they reach."""
    ids = cKDTree(v_in).query(zipped.vertices)[1]
    rows = np.sort(ids[zipped.faces], axis=1)
    return rows[np.lexsort(rows.T[::-1])], len(np.unique(ids))


def _sorted(f):
    rows = np.sort(f, axis=1)
    return rows[np.lexsort(rows.T[::-1])]


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("fixture", ["spot_mesh", "plane_mesh"])
def test_split_seams_after_noise_zip_back_to_the_input(fixture, seed, request):
    v, f = request.getfixturevalue(fixture)  # closed, and open with 27 boundary loops
    split_v, split_f = apply_attack("split_seams", v, f, seed=seed)
    assert len(split_v) > len(v)  # the seams were cut
    noisy, noisy_f = apply_attack("noise", split_v, split_f, seed=seed, amplitude=0.001)
    zipped = zip_borders(noisy, noisy_f)
    assert zipped.glued > 0
    faces, reached = _faces_as_input(v, zipped)
    assert len(zipped.vertices) == len(v) == reached
    np.testing.assert_array_equal(faces, _sorted(f))


@pytest.mark.parametrize("fixture", ["spot_mesh", "plane_mesh", "kitten_mesh"])
def test_a_mesh_without_split_seams_is_not_glued(fixture, request):
    v, f = request.getfixturevalue(fixture)
    zipped = zip_borders(v, f)
    assert zipped.glued == 0
    np.testing.assert_array_equal(zipped.faces, f)
    np.testing.assert_array_equal(zipped.vertices, v)


def test_holes_and_a_slit_wider_than_the_tolerance_stay_open():
    # A 6x6 grid of squares cut along its middle column line: the two sides of the cut apart
    # by more than the tolerance of an edge are not glued; nearer, they are.
    n = 6
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    base = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], axis=1).astype(float)
    quads = [(a * (n + 1) + b, (a + 1) * (n + 1) + b) for a in range(n) for b in range(n)]
    faces = []
    for p, q in quads:
        faces += [[p, q, q + 1], [p, q + 1, p + 1]]
    f = np.array(faces)
    # Copies of the vertices on the line x = 3 (not its ends), used by the faces right of it.
    line = np.flatnonzero((base[:, 0] == 3) & (base[:, 1] > 0) & (base[:, 1] < n))
    copy = {int(k): len(base) + c for c, k in enumerate(line)}
    right = base[f].mean(axis=1)[:, 0] > 3
    f2 = f.copy()
    for r in np.flatnonzero(right):
        f2[r] = [copy.get(int(k), int(k)) for k in f[r]]
    for gap, glued in ((0.5 * ZIP_TOLERANCE, True), (2.0 * ZIP_TOLERANCE, False)):
        v2 = np.vstack([base, base[line] + [gap, 0, 0]])
        zipped = zip_borders(v2, f2)
        assert (zipped.glued == len(line)) is glued  # the copies of the cut, or none
        assert len(zipped.vertices) == (len(base) if glued else len(v2))


@pytest.mark.parametrize("seed", range(10))
def test_zipping_does_not_depend_on_order_pose_or_scale(spot_mesh, seed):
    v, f = spot_mesh
    split_v, split_f = apply_attack("split_seams", v, f, seed=3)
    noisy, noisy_f = apply_attack("noise", split_v, split_f, seed=3, amplitude=0.001)
    zipped = zip_borders(noisy, noisy_f)
    rng = np.random.default_rng(seed)
    rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    scale = float(np.exp(rng.uniform(np.log(0.01), np.log(100))))
    shift = rng.uniform(-100, 100, size=3)
    order = rng.permutation(len(noisy))
    moved = (noisy[order] @ rotation.T) * scale + shift
    again = zip_borders(moved, np.argsort(order)[noisy_f][rng.permutation(len(noisy_f))])
    assert again.glued == zipped.glued
    expected = (zipped.vertices @ rotation.T) * scale + shift
    # The same vertices (in another order) and the same faces over them.
    near = cKDTree(expected).query(again.vertices)[1]
    assert len(np.unique(near)) == len(expected)
    size = np.abs(expected).max()
    np.testing.assert_allclose(again.vertices, expected[near], atol=1e-12 * size)
    np.testing.assert_array_equal(_sorted(near[again.faces]), _sorted(zipped.faces))
