"""Tests for :mod:`meshwm.attacks.smoothing`: uniform Laplacian, MeshLab's Laplacian, Taubin."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from _attack_checks import (
    _mean_centroid_distance,
    _roughness,
    _signed_volume,
    _square_fan,
)
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.attacks.smoothing import laplacian, meshlab_laplacian, taubin


def test_laplacian_step_by_hand():
    """λ = 1, one step: the interior vertex goes to the mean of its 6 neighbours; a border
    vertex to the mean of its 2 neighbours along the border (not its interior neighbours)."""
    v, f = _square_fan()
    v[4, 2] = 1.0  # lift the centre
    v[1, 2] = 0.5  # and a border midpoint
    out, out_f = laplacian(v, f, lam=1.0, iterations=1)
    assert_array_equal(out_f, f)
    ring = [v[k] for k in (0, 1, 3, 5, 7, 8)]  # neighbours of 4 by the diagonals chosen
    assert_allclose(out[4], np.mean(ring, axis=0), rtol=0, atol=1e-12)
    assert_allclose(out[1], (v[0] + v[2]) / 2, rtol=0, atol=1e-12)  # centre ignored
    assert_allclose(out[0], (v[1] + v[3]) / 2, rtol=0, atol=1e-12)
    half = laplacian(v, f, lam=0.5, iterations=1)[0]
    assert_allclose(half, (v + out) / 2, rtol=0, atol=1e-12)


def test_laplacian_smooths_more_with_more_iterations(mesh):
    v, f = mesh
    rough = [_roughness(v, f)]
    rough += [_roughness(laplacian(v, f, iterations=k)[0], f) for k in (5, 10, 30, 50)]
    assert all(a > b for a, b in itertools.pairwise(rough))
    assert rough[-1] < 0.6 * rough[0]


@pytest.mark.parametrize("attack", [laplacian, meshlab_laplacian, taubin])
def test_smoothing_reduces_roughness_and_stays_close(mesh, attack):
    v, f = mesh
    v2, f2 = attack(v, f)
    assert_array_equal(f2, f)
    assert _roughness(v2, f) < 0.95 * _roughness(v, f)
    assert np.linalg.norm(v2 - v, axis=1).max() < 0.1 * _mean_centroid_distance(v)


def test_taubin_keeps_the_volume_better_than_laplacian(mesh):
    v, f = mesh
    volume = abs(_signed_volume(v, f))
    shrink_taubin = abs(_signed_volume(taubin(v, f)[0], f) - volume)
    shrink_laplacian = abs(_signed_volume(meshlab_laplacian(v, f)[0], f) - volume)
    assert shrink_taubin < 0.25 * shrink_laplacian
