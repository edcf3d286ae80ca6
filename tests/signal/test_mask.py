"""Tests for :mod:`meshwm.signal.mask`: the crisp inputs of the fuzzy mask, computed from CA.

What the mask must do for blind extraction: give the same weights for any pose and size of CA
(rotation, reflection, translation, uniform scale) and nearly the same weights for a CA rounded
differently.  It must also tell flat from rough, select a useful share of the coefficients on
a real model, and reject bad input.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.spatial.transform import Rotation

from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.signal.fuzzy import EMBEDDING_CLASSES, infer_strength, strength_class
from meshwm.signal.mask import PerceptualInputs, perceptual_inputs, perceptual_weight
from meshwm.signal.wavelet import mrr_decompose

#: Largest weight change allowed under a change of pose (rotation, translation, scale).
POSE_ATOL = 1e-9
#: Largest weight change allowed under a relative perturbation of 1e-7 (float32 rounding).
PERTURBATION_ATOL = 1e-5
BLOCK = 4


def _ca(gim: np.ndarray) -> np.ndarray:
    """(N/2, N/2, 3): the level-1 Haar approximation of each coordinate matrix."""
    return np.stack([mrr_decompose(gim[..., k])["a"] for k in range(3)], axis=-1)


def _grid(side: int, height) -> np.ndarray:
    u, v = np.meshgrid(np.linspace(-1, 1, side), np.linspace(-1, 1, side), indexing="ij")
    return np.stack([u, v, height(u, v)], axis=-1)


def _rotation(seed: int, *, proper: bool = True) -> np.ndarray:
    matrix = Rotation.random(random_state=seed).as_matrix()
    return matrix if proper else matrix @ np.diag([1.0, 1.0, -1.0])


@pytest.fixture(scope="module")
def spot_ca(spot_mesh) -> np.ndarray:
    """CA of the geometry image of ``assets/spot.ply`` at size 128: (64, 64, 3)."""
    return _ca(mesh_to_geometry_image(*spot_mesh, size=128).gim)


@pytest.mark.parametrize("block", [1, 2, 4, 8, 32])
def test_shapes_and_ranges(spot_ca, block):
    m = spot_ca.shape[0] // block
    inputs = perceptual_inputs(spot_ca, block=block)
    assert isinstance(inputs, PerceptualInputs)
    for name, values in inputs._asdict().items():
        assert values.shape == (m, m), name
        assert values.dtype == np.float64, name
        assert np.all((values >= 0.0) & (values <= 1.0)), name
    weight = perceptual_weight(spot_ca, block=block)
    assert weight.shape == (m, m)
    assert np.all((weight >= 0.0) & (weight <= 1.0))


def test_weight_is_the_fis_of_the_inputs(spot_ca):
    expected = infer_strength(*perceptual_inputs(spot_ca, block=BLOCK))
    assert_array_equal(perceptual_weight(spot_ca, block=BLOCK), expected)


def test_median_block_maps_to_medium(spot_ca):
    """``x / (x + median)``: half the blocks on each side of 0.5."""
    for name, values in perceptual_inputs(spot_ca, block=BLOCK)._asdict().items():
        assert abs(float(np.median(values)) - 0.5) < 0.02, name


def test_input_is_not_modified(spot_ca):
    ca = spot_ca.copy()
    perceptual_weight(ca, block=BLOCK)
    assert_array_equal(ca, spot_ca)


@pytest.mark.parametrize("scale", [0.01, 1.0, 100.0])
@pytest.mark.parametrize("proper", [True, False], ids=["rotation", "reflection"])
def test_invariant_to_pose_and_scale(spot_ca, scale, proper):
    rotation = _rotation(7, proper=proper)
    assert np.isclose(np.linalg.det(rotation), 1.0 if proper else -1.0)
    moved = scale * spot_ca @ rotation.T + np.array([3.0, -1.5, 20.0])
    before = perceptual_inputs(spot_ca, block=BLOCK)
    after = perceptual_inputs(moved, block=BLOCK)
    for a, b in zip(before, after, strict=True):
        assert_allclose(b, a, rtol=0, atol=POSE_ATOL)
    assert_allclose(
        perceptual_weight(moved, block=BLOCK),
        perceptual_weight(spot_ca, block=BLOCK),
        rtol=0,
        atol=POSE_ATOL,
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_tiny_perturbation_moves_weights_tinily(spot_ca, seed):
    """A relative perturbation of 1e-7 (float32 rounding) must not move the mask."""
    noise = np.random.default_rng(seed).standard_normal(spot_ca.shape)
    weight = perceptual_weight(spot_ca, block=BLOCK)
    change = np.abs(perceptual_weight(spot_ca * (1 + 1e-7 * noise), block=BLOCK) - weight)
    print(f"max weight change under relative 1e-7 noise: {change.max():.2e}")
    assert change.max() < PERTURBATION_ATOL


def test_float32_rounding_keeps_the_classes(spot_ca):
    weight = perceptual_weight(spot_ca, block=BLOCK)
    rounded = perceptual_weight(spot_ca.astype(np.float32), block=BLOCK)
    assert np.abs(rounded - weight).max() < PERTURBATION_ATOL
    assert_array_equal(strength_class(rounded), strength_class(weight))


@pytest.mark.parametrize("seed", [0, 3])
def test_flat_plane_is_smooth_and_bumps_are_rough(seed):
    rotation = _rotation(seed)
    flat = _grid(32, lambda u, v: np.zeros_like(u)) @ rotation.T
    bumpy = _grid(32, lambda u, v: 0.05 * np.sin(9 * u) * np.cos(7 * v)) @ rotation.T
    flat_inputs = perceptual_inputs(flat, block=BLOCK)
    bumpy_inputs = perceptual_inputs(bumpy, block=BLOCK)
    # Rounding noise on a plane stays far below the floors: inputs near 0.
    assert flat_inputs.curvature.max() < 1e-6
    assert flat_inputs.bumpiness.max() < 1e-6
    assert bumpy_inputs.bumpiness.mean() > 0.3
    assert bumpy_inputs.curvature.mean() > 0.3
    assert np.all(bumpy_inputs.bumpiness > flat_inputs.bumpiness)
    # Flat and smooth: the lowest weights, never a carrier.
    carries = np.isin(strength_class(perceptual_weight(flat, block=BLOCK)), EMBEDDING_CLASSES)
    assert not carries.any()


def test_rougher_blocks_get_higher_bumpiness():
    """One half of the grid is rough: its bumpiness is the higher."""
    ca = _grid(32, lambda u, v: np.where(u > 0, 0.02 * np.sin(20 * u) * np.sin(20 * v), 0.0))
    bumpiness = perceptual_inputs(ca, block=BLOCK).bumpiness
    assert bumpiness[5:].min() > bumpiness[:3].max()


def test_coincident_points_give_zeros():
    ca = np.full((16, 16, 3), 2.5)
    for values in perceptual_inputs(ca, block=BLOCK):
        assert_array_equal(values, np.zeros((4, 4)))
    assert np.all(np.isfinite(perceptual_weight(ca, block=BLOCK)))


def test_collapsed_region_stays_finite_and_invariant(spot_ca):
    """Zero-area faces (a patch collapsed to one point) give finite, pose-invariant inputs."""
    ca = spot_ca.copy()
    ca[8:24, 8:24] = ca[8, 8]
    ca[40:44] = ca[40:41]  # four rows collapsed onto one curve
    inputs = perceptual_inputs(ca, block=BLOCK)
    for values in inputs:
        assert np.all(np.isfinite(values))
        assert np.all((values >= 0.0) & (values <= 1.0))
    assert_array_equal(inputs.area[3:5, 3:5], 0.0)  # blocks inside the collapsed patch
    moved = 0.5 * ca @ _rotation(11).T + 1.0
    assert_allclose(
        perceptual_weight(moved, block=BLOCK),
        perceptual_weight(ca, block=BLOCK),
        rtol=0,
        atol=POSE_ATOL,
    )


def test_high_and_higher_share_on_spot(spot_ca):
    """On a real model the mask selects a useful share of the coefficients, not all or none."""
    weight = perceptual_weight(spot_ca, block=BLOCK)
    share = float(np.isin(strength_class(weight), EMBEDDING_CLASSES).mean())
    print(f"spot, CA 64×64, block {BLOCK}: HIGH or HIGHER share {share:.3f}")
    assert 0.1 <= share <= 0.9


@pytest.mark.parametrize(
    ("shape", "match"),
    [
        ((64, 64), r"\(M, M, 3\).*got shape \(64, 64\)"),
        ((64, 64, 2), r"got shape \(64, 64, 2\)"),
        ((64, 32, 3), r"got shape \(64, 32, 3\)"),
        ((24, 24, 3), r"power of two >= 8, got shape \(24, 24, 3\)"),
        ((4, 4, 3), r"power of two >= 8, got shape \(4, 4, 3\)"),
    ],
)
def test_bad_shape_raises(shape, match):
    with pytest.raises(ValueError, match=match):
        perceptual_inputs(np.zeros(shape), block=2)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_raises(bad):
    ca = _grid(16, lambda u, v: u * v)
    ca[3, 5, 2] = bad
    with pytest.raises(ValueError, match="1 NaN or infinite"):
        perceptual_weight(ca, block=4)


@pytest.mark.parametrize("block", [0, 3, 6, 32, 64, -4])
def test_bad_block_raises(block):
    with pytest.raises(ValueError, match=rf"block must be a power of two.*got {block}$"):
        perceptual_inputs(_grid(32, lambda u, v: u * v), block=block)


@pytest.mark.parametrize("block", [4.0, True, "4", None])
def test_block_must_be_an_int(block):
    with pytest.raises(TypeError, match="block must be an int"):
        perceptual_inputs(_grid(16, lambda u, v: u * v), block=block)


@pytest.mark.parametrize("dtype", [np.bool_, np.complex128, object])
def test_ca_must_be_real(dtype):
    with pytest.raises(TypeError, match="ca must hold real numbers"):
        perceptual_inputs(np.zeros((16, 16, 3), dtype=dtype), block=4)


def test_integer_ca_is_accepted():
    ca = np.round(_grid(16, lambda u, v: np.sin(3 * u) * v) * 100).astype(np.int32)
    assert_allclose(
        perceptual_weight(ca, block=4),
        perceptual_weight(ca.astype(np.float64), block=4),
        rtol=0,
        atol=0,
    )
