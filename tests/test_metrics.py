"""Tests for :mod:`meshwm.metrics`: PSNR, bit error rate and corr2.

The reference is numpy's ``corrcoef`` (for MATLAB's ``corr2``).
"""

from __future__ import annotations

import numpy as np
import pytest
from _border import border_reach
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose

from meshwm.metrics import (
    bit_error_rate,
    bounding_box_diagonal,
    correlation2,
    psnr,
    surface_distance,
)

#: Agreement between two float64 formulas of the same quantity.
RTOL = 1e-12


@pytest.fixture(scope="module")
def image() -> np.ndarray:
    n = 32
    i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    return np.stack([i, j, 0.2 * np.sin(5 * i) * np.cos(3 * j)], axis=-1)


@pytest.fixture(scope="module")
def pattern(image) -> np.ndarray:
    return np.random.default_rng(0).normal(size=image.shape)


# --- psnr ----------------------------------------------------------------------------------


def test_psnr_of_identical_images_is_infinite(image):
    assert psnr(image, image.copy()) == float("inf")


def test_psnr_decreases_as_noise_grows(image, pattern):
    values = [psnr(image, image + sigma * pattern) for sigma in (1e-5, 1e-4, 1e-3, 1e-2)]
    assert all(np.isfinite(values))
    assert values == sorted(values, reverse=True) and len(set(values)) == len(values)
    # Ten times the same noise is 20 dB less: PSNR is 20 log10(peak / rms).
    assert_allclose(np.diff(values), -20.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("scale", [1e-3, 7.0, 1e4])
def test_psnr_ignores_scale_and_translation(image, pattern, scale):
    marked = image + 1e-3 * pattern
    shift = np.array([3.0, -1.0, 100.0])
    assert_allclose(
        psnr(scale * image + shift, scale * marked + shift), psnr(image, marked), rtol=1e-9
    )


def test_psnr_peak_is_the_bounding_box_diagonal(image):
    """One coordinate off by d/10 in every sample: rms = d / (10 sqrt 3), so 20 log10(10 sqrt 3)."""
    diag = np.linalg.norm(image.reshape(-1, 3).max(axis=0) - image.reshape(-1, 3).min(axis=0))
    marked = image.copy()
    marked[..., 1] += diag / 10
    assert_allclose(psnr(image, marked), 20 * np.log10(10 * np.sqrt(3)), rtol=RTOL)


@pytest.mark.parametrize(
    ("a", "b"),
    [((4, 4, 3), (4, 4, 2)), ((4, 4, 2), (4, 4, 2)), ((4, 4, 3), (3, 4, 3))],
)
def test_psnr_refuses_mismatched_shapes(a, b):
    with pytest.raises(ValueError, match="need two"):
        psnr(np.zeros(a), np.zeros(b))


# --- correlation2 ------------------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(
    shape=st.tuples(st.integers(2, 12), st.integers(1, 12)),
    seed=st.integers(0, 2**32 - 1),
    binary=st.booleans(),
)
def test_correlation2_matches_corrcoef(shape, seed, binary):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=shape)
    b = 0.3 * a + rng.normal(size=shape)
    if binary:
        a, b = (a > 0).astype(np.uint8), (b > 0).astype(np.uint8)
    assume(a.std() > 0 and b.std() > 0)  # constants: see test_correlation2_of_a_constant_is_nan
    expected = np.corrcoef(a.ravel().astype(float), b.ravel().astype(float))[0, 1]
    assert_allclose(correlation2(a, b), expected, rtol=1e-10, atol=1e-12)


@given(arrays(np.float64, (5, 5), elements=st.floats(-1e3, 1e3)))
@settings(max_examples=30, deadline=None)
def test_correlation2_with_itself_is_one(a):
    assume(np.ptp(a) > 1e-9 * (1 + np.abs(a).max()))
    assert_allclose(correlation2(a, a), 1.0, rtol=1e-9)
    assert_allclose(correlation2(a, -a), -1.0, rtol=1e-9)


def test_correlation2_is_symmetric_and_affine_invariant():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 8, 8))
    r = correlation2(a, b)
    assert -1 <= r <= 1
    assert_allclose(correlation2(b, a), r, rtol=RTOL)
    assert_allclose(correlation2(5 * a + 3, 0.1 * b - 2), r, rtol=1e-10)
    assert_allclose(correlation2(-a, b), -r, rtol=RTOL)


def _constant_pairs(value: float) -> list[tuple[np.ndarray, np.ndarray]]:
    constant = np.full((5, 5), value)
    return [(constant, np.eye(5)), (np.eye(5), constant), (constant, constant)]


@pytest.mark.parametrize("value", [0.0, 1.0, -7.0, 0.5])
def test_correlation2_of_a_constant_is_nan(value):
    for a, b in _constant_pairs(value):
        assert np.isnan(correlation2(a, b))


@pytest.mark.parametrize("value", [0.1, 1 / 3])
def test_correlation2_of_an_inexact_constant_is_nan(value):
    for a, b in _constant_pairs(value):
        assert np.isnan(correlation2(a, b))


@pytest.mark.parametrize(("a", "b"), [((4, 4), (4, 3)), ((0,), (0,)), ((4, 4), (16,))])
def test_correlation2_refuses_mismatched_or_empty(a, b):
    with pytest.raises(ValueError, match="need two non-empty arrays"):
        correlation2(np.zeros(a), np.zeros(b))


# --- bit_error_rate ------------------------------------------------------------------------


@pytest.mark.parametrize("flips", [0, 1, 17, 1024])
def test_bit_error_rate_counts_flipped_bits(flips):
    rng = np.random.default_rng(flips)
    bits = rng.integers(0, 2, size=(32, 32)).astype(np.uint8)
    found = bits.copy().ravel()
    where = rng.choice(found.size, size=flips, replace=False)
    found[where] ^= 1
    assert bit_error_rate(bits, found.reshape(bits.shape)) == flips / bits.size


def test_bit_error_rate_is_symmetric():
    rng = np.random.default_rng(3)
    a, b = rng.integers(0, 2, size=(2, 100))
    assert bit_error_rate(a, b) == bit_error_rate(b, a)


@pytest.mark.parametrize(("a", "b"), [((4,), (5,)), ((0,), (0,)), ((2, 2), (4,))])
def test_bit_error_rate_refuses_mismatched_or_empty(a, b):
    with pytest.raises(ValueError, match="need two non-empty arrays"):
        bit_error_rate(np.zeros(a), np.zeros(b))


# --- surface_distance ----------------------------------------------------------------------


def test_surface_distance_sees_a_chord_across_a_hole(slid_rim):
    # Every vertex of either mesh lies on the other surface; only the rim's chords are off
    # it.  MeshLab's 200 random samples alone put the Hausdorff distance at 0.08 % of the
    # diagonal, 2,000 at 0.09 %: it is 0.2 %.
    v, f, slid = slid_rim
    diag = bounding_box_diagonal(v)
    brute = max(border_reach(v, f, slid), border_reach(slid, f, v))
    assert brute > 1.5e-3 * diag
    for samples in (200, 2000):
        d = surface_distance(v, f, slid, f, samples=samples)
        assert d.hausdorff == pytest.approx(brute, rel=1e-6)
        assert d.rms < 0.2 * d.hausdorff  # the RMS is MeshLab's, of its samples
