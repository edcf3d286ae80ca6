"""Tests for :mod:`meshwm.profiles.radial`: the radial carrier's slots, projections, reading."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.errors import CapacityError
from meshwm.profiles import get_decoder
from meshwm.profiles.radial.scheme import (
    RADIAL_STEP,
    band,
    band_adjoint,
    lattice_change,
    radial_layout,
    radial_projections,
    radial_spread,
    read_radial_bits,
)
from meshwm.readers.base import SampledImage


def test_the_layout_is_the_keys_alone():
    a, b = radial_layout(128, "key", 256), radial_layout(128, "key", 256)
    assert_array_equal(a.slots, b.slots)
    assert_array_equal(a.signs, b.signs)
    assert_array_equal(a.dither, b.dither)
    other = radial_layout(128, "another key", 256)
    assert not np.array_equal(a.slots, other.slots)
    assert a.slots.shape == (256, 3)
    # Every slot is dealt at most once.
    assert len(np.unique(a.slots)) == a.slots.size


def test_a_payload_larger_than_the_slots_is_refused():
    with pytest.raises(CapacityError, match="768 slots"):
        radial_layout(128, "k", 1024)


def test_band_and_projections_have_their_adjoints():
    rng = np.random.default_rng(0)
    n = 64
    x = rng.normal(size=(n, n))
    y = rng.normal(size=3 * (n // 8) ** 2)
    assert float(band(x) @ y) == pytest.approx(float(np.sum(x * band_adjoint(y, n))), rel=1e-12)
    lay = radial_layout(n, "k", 20)
    z = rng.normal(size=20)
    lhs = float(radial_projections(x, lay) @ z)
    assert lhs == pytest.approx(float(np.sum(x * radial_spread(z, lay))), rel=1e-12)
    # Stacks go through in one call.
    stack = radial_spread(np.eye(20), lay)
    assert stack.shape == (20, n, n)
    assert_allclose(radial_projections(stack, lay), np.eye(20), atol=1e-12)


def test_moving_to_the_lattice_reads_every_bit_and_a_random_image_reads_at_chance():
    rng = np.random.default_rng(1)
    n, k = 128, 256
    lay = radial_layout(n, "k", k)
    bits = rng.integers(0, 2, k).astype(np.uint8)
    image = rng.normal(size=(n, n))
    proj = radial_projections(image, lay)
    change = lattice_change(proj, bits, lay)
    assert np.abs(change).max() <= RADIAL_STEP / 2 + 1e-15
    got, confidence = read_radial_bits(proj + change, lay)
    assert_array_equal(got, bits)
    assert_allclose(np.abs(confidence), 1.0, atol=1e-9)
    # The image itself (no mark): about half the bits, and a weak read as a whole.
    decoder = get_decoder("radial", "robust")
    found = decoder.decode(decoder.prepare(SampledImage(image[..., None], 1, "radial")), k, key="k")
    assert 0.35 < np.mean(found.bits != bits) < 0.65
    assert np.mean(np.abs(found.confidence)) < 0.2


def test_the_decoder_reads_nothing_when_the_image_has_too_few_slots():
    decoder = get_decoder("radial", "robust")
    prepared = decoder.prepare(SampledImage(np.zeros((64, 64, 1)), 1, "radial"))
    found = decoder.decode(prepared, 1024, key="k")
    assert_array_equal(found.confidence, 0.0)
    with pytest.raises(ValueError, match="unknown scheme"):
        get_decoder("spiral", "robust")
