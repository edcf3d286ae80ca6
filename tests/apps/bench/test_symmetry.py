"""Tests for :mod:`meshwm.apps.bench.symmetry`: a mesh's exact rotational symmetries, and the
surface image of the genus-8 plate stable up to its half turn."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.apps.bench.symmetry import proper_symmetries, random_similarity, up_to_symmetry
from meshwm.apps.bench.synthetic import make
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.surface import sample_surface, surface_of
from meshwm.metrics import bounding_box_diagonal


@pytest.fixture(scope="module")
def plate():
    return make("genus8")


def test_the_plate_has_its_half_turn_and_nothing_else(plate):
    v, f = plate
    found = proper_symmetries(v, f)
    assert len(found) == 2
    np.testing.assert_allclose(found[0], np.eye(3))
    half = found[1]
    # A half turn: symmetric, orthogonal, trace -1, about the plate's normal (z).
    np.testing.assert_allclose(half @ half, np.eye(3), atol=1e-12)
    assert abs(np.trace(half) + 1) < 1e-9 and half[2, 2] > 1 - 1e-9


def test_a_jitter_or_a_scan_has_none(kitten_mesh):
    assert len(proper_symmetries(*make("genus8_jittered"))) == 1
    assert len(proper_symmetries(*kitten_mesh)) == 1


def test_the_half_turn_is_found_in_any_pose(plate):
    v, f = plate
    half = proper_symmetries(v, f)[1]
    rng = np.random.default_rng(4)
    for _ in range(6):
        mv, mf, q, _ = random_similarity(rng, v, f)
        found = proper_symmetries(mv, mf)
        assert len(found) == 2
        np.testing.assert_allclose(found[1], q @ half @ q.T, atol=1e-8)


def test_a_reversed_face_is_not_a_symmetry(plate):
    v, f = plate
    g = f.copy()
    g[0] = g[0, ::-1]  # one face wound the other way: the half turn no longer maps faces
    assert len(proper_symmetries(v, g)) == 1


def test_the_surface_image_is_the_inputs_up_to_the_half_turn(plate):
    """Rounding decides between the plate's two cut starts (each other's half turn), so about
    half the similarities give the input's image turned; none gives another image."""
    v, f = plate
    turns = proper_symmetries(v, f)
    centre = v.mean(axis=0)
    diag = bounding_box_diagonal(v)
    base = sample_surface(surface_of(v, f), size=128).samples
    rng = np.random.default_rng(13)
    exact = 0
    for _ in range(12):
        mv, mf, _, back = random_similarity(rng, v, f)
        got = back(sample_surface(surface_of(mv, mf), size=128).samples.reshape(-1, 3))
        got = got.reshape(base.shape)
        assert up_to_symmetry(got, base, turns, centre) < 1e-9 * diag
        exact += up_to_symmetry(got, base, turns[:1], centre) < 1e-9 * diag
    assert 0 < exact < 12  # both of the two images occur: the tie is real


@pytest.mark.slow
def test_the_grid_image_is_the_inputs_up_to_the_half_turn(plate):
    """The remesh runs on the plate's canonical copy (:func:`meshwm.gim.pose.canonical_mesh`):
    the same arrays in both poses its frame may take, so the input's grid image or its half
    turn, never another (before it: 8 of 20 similarities, its cuts' exact ties decided by
    rounding)."""
    v, f = plate
    turns = proper_symmetries(v, f)
    centre = v.mean(axis=0)
    diag = bounding_box_diagonal(v)
    base = mesh_to_geometry_image(v, f, size=64).gim
    rng = np.random.default_rng(17)
    exact = 0
    for _ in range(10):
        mv, mf, _, back = random_similarity(rng, v, f)
        got = back(mesh_to_geometry_image(mv, mf, size=64).gim.reshape(-1, 3))
        got = got.reshape(base.shape)
        assert up_to_symmetry(got, base, turns, centre) < 1e-9 * diag
        exact += up_to_symmetry(got, base, turns[:1], centre) < 1e-9 * diag
    assert 0 < exact < 10


def test_images_that_cover_other_samples_differ():
    im = np.zeros((2, 2, 3))
    other = im.copy()
    other[0, 0] = np.nan
    assert up_to_symmetry(other, im, [np.eye(3)], np.zeros(3)) == np.inf
