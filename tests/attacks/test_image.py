"""Tests for :mod:`meshwm.attacks.image`: the paper's attacks on the geometry image (N = 64)."""

from __future__ import annotations

import numpy as np
import pytest
from _attack_checks import (
    GIM,
)
from numpy.testing import assert_allclose, assert_array_equal
from scipy.ndimage import correlate

from meshwm.attacks import apply_attack
from meshwm.attacks.image import (
    fspecial_gaussian,
    fspecial_laplacian,
    fspecial_log,
    gim_crop,
    gim_gaussian,
    gim_laplacian,
    gim_log,
    gim_noise,
    gim_salt_pepper,
)
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid

# --- the paper's attacks on the geometry image ----------------------------------------------


def test_fspecial_matches_matlab():
    """Golden values: MATLAB's documented output of ``fspecial('gaussian')``, ``fspecial('log')``
    (both with their defaults, [3 3] / 0.5 and [5 5] / 0.5) and ``fspecial('laplacian')``
    (alpha 0.2), 4 decimals."""
    assert_allclose(
        fspecial_gaussian(3, 0.5),
        [[0.0113, 0.0838, 0.0113], [0.0838, 0.6193, 0.0838], [0.0113, 0.0838, 0.0113]],
        atol=5e-5,
    )
    assert_allclose(
        fspecial_log(5, 0.5),
        [
            [0.0448, 0.0468, 0.0564, 0.0468, 0.0448],
            [0.0468, 0.3167, 0.7146, 0.3167, 0.0468],
            [0.0564, 0.7146, -4.9048, 0.7146, 0.0564],
            [0.0468, 0.3167, 0.7146, 0.3167, 0.0468],
            [0.0448, 0.0468, 0.0564, 0.0468, 0.0448],
        ],
        atol=5e-5,
    )
    assert_allclose(
        fspecial_laplacian(0.2),
        [[0.1667, 0.6667, 0.1667], [0.6667, -3.3333, 0.6667], [0.1667, 0.6667, 0.1667]],
        atol=5e-5,
    )
    for h in (fspecial_gaussian(7, 10.0), fspecial_gaussian(3, 10.0)):
        assert_allclose(h.sum(), 1.0, rtol=1e-12)
        assert_allclose(h, h.T, rtol=0, atol=0)
    assert_allclose(fspecial_log(7, 1.3).sum(), 0.0, atol=1e-12)
    assert_allclose(fspecial_laplacian(1.0).sum(), 0.0, atol=1e-12)


def _gim(v, f) -> np.ndarray:
    return recover_grid(v, f).gim


def _interior(n: int) -> tuple[slice, slice]:
    """Samples off the border: never welded, so each has a vertex of its own."""
    return slice(1, n - 1), slice(1, n - 1)


@pytest.mark.parametrize(
    ("attack", "kernel", "smoothing"),
    [
        (lambda v, f: gim_gaussian(v, f, hsize=3, sigma=10.0), fspecial_gaussian(3, 10.0), False),
        (lambda v, f: gim_gaussian(v, f, hsize=7, sigma=10.0), fspecial_gaussian(7, 10.0), False),
        (lambda v, f: gim_log(v, f), fspecial_log(5, 0.5), True),
        (lambda v, f: gim_laplacian(v, f, alpha=1.0), fspecial_laplacian(1.0), True),
        (lambda v, f: gim_laplacian(v, f, alpha=0.2), fspecial_laplacian(0.2), True),
    ],
    ids=["gaussian3", "gaussian7", "log", "laplacian1", "laplacian0.2"],
)
def test_gim_filters_each_matrix_with_the_matlab_kernel(gim_mesh, attack, kernel, smoothing):
    v, f = gim_mesh
    before = _gim(v, f)
    v2, f2 = attack(v, f)
    assert_array_equal(f2, f)
    after = _gim(v2, f2)
    expected = np.stack(
        [correlate(before[..., k], kernel, mode="nearest") for k in range(3)], axis=-1
    )
    if smoothing:
        r = kernel.shape[0] // 2
        expected = before - expected / kernel[r, r]
    inside = _interior(len(before))
    assert_allclose(after[inside], expected[inside], rtol=0, atol=1e-12)


def test_gim_laplacian_alpha_1_is_the_mean_of_the_diagonal_neighbours(gim_mesh):
    v, f = gim_mesh
    g = _gim(v, f)
    out = _gim(*gim_laplacian(v, f, alpha=1.0))
    i, j = 20, 33
    corners = g[[i - 1, i - 1, i + 1, i + 1], [j - 1, j + 1, j - 1, j + 1]]
    assert_allclose(out[i, j], corners.mean(axis=0), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", GIM)
def test_gim_attack_keeps_the_grid_and_welds(gim_mesh, name):
    """Same faces, every vertex written once: the result still reads as the same grid, and the
    welded seam stays closed (no new vertex, no new boundary)."""
    v, f = gim_mesh
    v2, f2 = apply_attack(name, v, f, seed=3)
    assert_array_equal(f2, f)
    assert v2.shape == v.shape
    grid = recover_grid(v2, f2)
    assert_array_equal(grid.index, recover_grid(v, f).index)
    assert np.any(np.abs(v2 - v) > 1e-9)


@pytest.mark.parametrize("name", GIM)
def test_gim_attack_does_not_depend_on_the_vertex_order(gim_mesh, name):
    """The grid comes from the connectivity, the noise is drawn in grid order: attacking a
    reordered file moves every surface point exactly as attacking the original does."""
    v, f = gim_mesh
    rng = np.random.default_rng(8)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    v2, _ = apply_attack(name, v, f, seed=5)
    v3, f3 = apply_attack(name, v[perm], inverse[f], seed=5)
    assert_array_equal(f3, inverse[f])
    assert_array_equal(v3, v2[perm])


@pytest.mark.parametrize("name", GIM)
def test_gim_attack_on_a_mesh_not_written_by_meshwm_raises(mesh, name):
    with pytest.raises(ValueError, match="gim attacks need a mesh written by meshwm") as info:
        apply_attack(name, *mesh)
    assert isinstance(info.value, GridError)


def test_gim_attack_leaves_other_components_alone(gim_mesh):
    """meshwm passes the input's smaller components through after the grid."""
    v, f = gim_mesh
    extra_v = np.array([[5.0, 5, 5], [6, 5, 5], [5, 6, 5], [5, 5, 6]])
    extra_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + len(v)
    v_all, f_all = np.vstack([v, extra_v]), np.vstack([f, extra_f])
    out, out_f = gim_noise(v_all, f_all, seed=2)
    assert_array_equal(out_f, f_all)
    assert_array_equal(out[len(v) :], extra_v)
    assert_array_equal(out[: len(v)], gim_noise(v, f, seed=2)[0])


@pytest.mark.parametrize("density", [0.05, 0.10])
def test_gim_salt_pepper_density(gim_mesh, density):
    v, f = gim_mesh
    g = _gim(v, f)
    out = _gim(*gim_salt_pepper(v, f, seed=1, density=density))
    inside = _interior(len(g))
    for k in range(3):
        x, y = g[..., k][inside], out[..., k][inside]
        changed = y != x
        low, high = y == g[..., k].min(), y == g[..., k].max()
        assert np.all(low | high | ~changed)  # a sample is kept, or set to the min or the max
        hit = (low | high).mean()
        assert abs(hit - density) < 0.3 * density
        assert abs(low.mean() - high.mean()) < 0.3 * density


@pytest.mark.parametrize("amplitude", [0.001, 0.1])
def test_gim_noise_is_bounded_by_amplitude_times_the_range(gim_mesh, amplitude):
    v, f = gim_mesh
    g = _gim(v, f)
    out = _gim(*gim_noise(v, f, seed=1, amplitude=amplitude))
    bound = amplitude * (g.max(axis=(0, 1)) - g.min(axis=(0, 1)))
    delta = np.abs(out - g)
    assert np.all(delta <= bound * (1 + 1e-9))
    inside = _interior(len(g))
    assert_allclose(delta[inside].reshape(-1, 3).mean(axis=0), bound / 2, rtol=0.1)


@pytest.mark.parametrize("fraction", [0.09, 0.16])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gim_crop_collapses_a_square_block(gim_mesh, fraction, seed):
    v, f = gim_mesh
    g = _gim(v, f)
    out = _gim(*gim_crop(v, f, seed=seed, fraction=fraction))
    n = len(g)
    side = round(np.sqrt(fraction) * n)
    changed = np.any(out != g, axis=-1)
    rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
    # All changes inside one side×side block, whose samples all share one point: its mean.
    assert rows.max() - rows.min() < side and cols.max() - cols.min() < side
    i0 = min(rows.min(), n - side)
    j0 = min(cols.min(), n - side)
    candidates = [
        (i, j)
        for i in range(max(0, rows.max() - side + 1), i0 + 1)
        for j in range(max(0, cols.max() - side + 1), j0 + 1)
        if np.ptp(out[i : i + side, j : j + side].reshape(-1, 3), axis=0).max() == 0
    ]
    assert candidates
    i, j = candidates[0]
    assert_allclose(
        out[i, j], g[i : i + side, j : j + side].reshape(-1, 3).mean(axis=0), rtol=0, atol=1e-12
    )
    assert abs(side * side / n**2 - fraction) < 0.01
