"""Tests for :mod:`meshwm.gim.transfer`: an image change carried onto the mesh's own vertices."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.sparse.linalg import lsqr

from meshwm.gim.code import grid_faces
from meshwm.gim.sampling import bilinear_matrix, grid_points, sampling_matrix
from meshwm.gim.transfer import (
    DEFAULT_SMOOTHNESS,
    Transfer,
    grid_laplacian,
    transfer_changes,
    uniform_laplacian,
)

#: Relative RMS of (re-sampled change - wanted change) on covered points, measured 0.4 % (N 64)
#: and 1.6 % (N 128) on the sheet below; the bound leaves room for other BLAS builds.
RMS_BOUND = {64: 0.01, 128: 0.03}


@pytest.fixture(scope="module")
def curved_sheet() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A gently curved sheet over the unit square: 64 × 64 jittered vertices, uv = xy."""
    rng = np.random.default_rng(13)
    k = 64
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    uv = np.stack([j.ravel(), i.ravel()], axis=1) / (k - 1)
    inner = ((i > 0) & (i < k - 1) & (j > 0) & (j < k - 1)).ravel()
    uv[inner] += rng.uniform(-0.3, 0.3, (int(inner.sum()), 2)) / (k - 1)
    height = 0.1 * np.sin(np.pi * uv[:, 0]) * np.sin(np.pi * uv[:, 1])
    return np.column_stack([uv, height]), grid_faces(k), uv


def band_limited(n: int, rng: np.random.Generator, *, cycles: int = 4) -> np.ndarray:
    """A smooth (n, n, 3) change: three random sinusoids of up to ``cycles`` per side, per axis."""
    g = grid_points(n).reshape(n, n, 2)
    out = np.zeros((n, n, 3))
    for axis in range(3):
        for _ in range(3):
            fu, fv = rng.integers(1, cycles + 1, 2)
            pu, pv = rng.uniform(0, 2 * np.pi, 2)
            wave = np.sin(2 * np.pi * fu * g[..., 0] + pu) * np.cos(2 * np.pi * fv * g[..., 1] + pv)
            out[..., axis] += rng.normal() * wave
    return 1e-3 * out / np.abs(out).max()


def relative_rms(sampling, displacement: np.ndarray, changes: np.ndarray) -> float:
    n = sampling.covered.shape[0]
    got = (sampling.matrix @ displacement).reshape(n, n, 3)[sampling.covered]
    want = changes[sampling.covered]
    return float(np.sqrt(((got - want) ** 2).mean() / (want**2).mean()))


@pytest.mark.parametrize("energy", ["bilaplacian", "dirichlet"])
@pytest.mark.parametrize("n", [64, 128])
def test_the_resampled_change_matches_a_smooth_target(curved_sheet, n, energy):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, n)
    changes = band_limited(n, np.random.default_rng(n))
    d = transfer_changes(vertices, faces, sampling, changes, energy=energy)
    assert d.shape == vertices.shape and d.dtype == np.float64
    assert relative_rms(sampling, d, changes) < RMS_BOUND[n]
    # Smooth, no spikes: no vertex moves much beyond the largest wanted change.
    assert np.abs(d).max() <= 1.5 * np.abs(changes).max()


@pytest.mark.parametrize("energy", ["bilaplacian", "dirichlet"])
def test_smoothness_removes_the_spikes_of_plain_least_squares(curved_sheet, energy):
    """With more vertices than grid points (V/N² = 4) minimum-norm least squares moves only the
    vertices of sampled triangles (roughness 0.88, max |d| 1.3 × max |change|); the smoothness
    term spreads the change over all of them (0.04, 1.02 ×)."""
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 32)
    changes = band_limited(32, np.random.default_rng(5))
    data = sampling.matrix[sampling.covered.ravel()]
    target = changes[sampling.covered]
    plain = np.column_stack(
        [lsqr(data, target[:, k], atol=1e-12, btol=1e-12, iter_lim=20_000)[0] for k in range(3)]
    )
    smooth = transfer_changes(vertices, faces, sampling, changes, energy=energy)
    laplacian = uniform_laplacian(faces, len(vertices))

    def roughness(d: np.ndarray) -> float:
        return float(np.linalg.norm(laplacian @ d) / np.linalg.norm(d))

    assert roughness(smooth) < 0.2 * roughness(plain)
    assert np.abs(smooth).max() < np.abs(plain).max()
    assert relative_rms(sampling, smooth, changes) < 1e-3


def test_more_passes_fit_the_data_at_least_as_well(curved_sheet):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 64)
    changes = band_limited(64, np.random.default_rng(2))
    errors = [
        relative_rms(
            sampling,
            transfer_changes(vertices, faces, sampling, changes, smoothness=1.0, passes=p),
            changes,
        )
        for p in (1, 2, 4)
    ]
    assert errors[0] > errors[1] > errors[2]


def test_the_transfer_is_linear_and_zero_gives_zero(curved_sheet):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 64)
    changes = band_limited(64, np.random.default_rng(3))
    d = transfer_changes(vertices, faces, sampling, changes)
    assert_allclose(transfer_changes(vertices, faces, sampling, -2 * changes), -2 * d, atol=1e-15)
    zero = transfer_changes(vertices, faces, sampling, np.zeros_like(changes))
    assert_array_equal(zero, 0.0)


def test_unsampled_parts_do_not_move_and_uncovered_changes_are_ignored(curved_sheet):
    vertices, faces, uv = curved_sheet
    k = len(vertices)
    # A second copy of the sheet mapped outside the unit square, and one vertex on no face.
    all_vertices = np.vstack([vertices, vertices + np.array([2.0, 0.0, 0.0]), [[5.0, 5.0, 5.0]]])
    all_faces = np.vstack([faces, faces + k])
    all_uv = np.vstack([uv, uv + 2.0, [[0.5, 0.5]]])
    sampling = sampling_matrix(all_uv, all_faces, 64)
    changes = band_limited(64, np.random.default_rng(4))
    d = transfer_changes(all_vertices, all_faces, sampling, changes)
    assert_allclose(d[k:], 0.0, rtol=0, atol=1e-12)
    # The same smoothness weight per vertex row (it is scaled by m / V, see Notes).
    weight = DEFAULT_SMOOTHNESS * k / len(all_vertices)
    alone = transfer_changes(
        vertices, faces, sampling_matrix(uv, faces, 64), changes, smoothness=weight
    )
    assert_allclose(d[:k], alone, rtol=0, atol=1e-9)


def test_vertex_and_face_order_change_nothing(curved_sheet):
    vertices, faces, uv = curved_sheet
    rng = np.random.default_rng(8)
    changes = band_limited(64, np.random.default_rng(9))
    reference = transfer_changes(vertices, faces, sampling_matrix(uv, faces, 64), changes)
    perm = rng.permutation(len(vertices))  # new vertex k is old vertex perm[k]
    new_faces = np.argsort(perm)[faces][rng.permutation(len(faces))]
    d = transfer_changes(
        vertices[perm], new_faces, sampling_matrix(uv[perm], new_faces, 64), changes
    )
    assert_allclose(d, reference[perm], rtol=0, atol=1e-12)


def test_inputs_are_not_modified(curved_sheet):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 64)
    changes = band_limited(64, np.random.default_rng(6))
    copies = vertices.copy(), faces.copy(), changes.copy(), sampling.matrix.copy()
    transfer_changes(vertices, faces, sampling, changes)
    assert_array_equal(vertices, copies[0])
    assert_array_equal(faces, copies[1])
    assert_array_equal(changes, copies[2])
    assert (sampling.matrix != copies[3]).nnz == 0


def test_the_uniform_laplacian_counts_a_shared_edge_once():
    laplacian = uniform_laplacian(np.array([[0, 1, 2], [0, 2, 3]]), 5).toarray()
    third = 1 / 3
    assert_allclose(laplacian[0], [1, -third, -third, -third, 0], rtol=0, atol=1e-15)
    assert_allclose(laplacian[1], [-0.5, 1, -0.5, 0, 0], rtol=0, atol=1e-15)
    assert_array_equal(laplacian[4], 0.0)  # a vertex on no edge
    assert_allclose(uniform_laplacian(grid_faces(6), 36) @ np.ones(36), 0.0, atol=1e-15)


@pytest.mark.parametrize(
    ("change", "options", "match"),
    [
        (lambda c: c[:-1], {}, "changes must have shape"),
        (lambda c: c[..., :2], {}, "changes must have shape"),
        (lambda c: np.where(c == c.max(), np.nan, c), {}, "changes must be finite"),
        (lambda c: c, {"smoothness": 0.0}, "smoothness must be"),
        (lambda c: c, {"smoothness": np.nan}, "smoothness must be"),
        (lambda c: c, {"passes": 0}, "passes must be >= 1"),
        (
            lambda c: c,
            {"energy": "laplace"},
            r"energy must be one of \['bilaplacian', 'dirichlet'\]",
        ),
    ],
)
def test_bad_input_raises_a_value_error_naming_the_parameter(curved_sheet, change, options, match):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 16)
    changes = band_limited(16, np.random.default_rng(0))
    with pytest.raises(ValueError, match=match):
        transfer_changes(vertices, faces, sampling, change(changes), **options)


def test_a_sampling_of_another_mesh_is_refused(curved_sheet):
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 16)
    with pytest.raises(ValueError, match="sampling must be of the"):
        transfer_changes(vertices[:-1], faces[:10], sampling, np.zeros((16, 16, 3)))
    with pytest.raises(ValueError, match="vertices must have shape"):
        transfer_changes(vertices[:, :2], faces, sampling, np.zeros((16, 16, 3)))
    with pytest.raises(ValueError, match="faces must index"):
        transfer_changes(vertices, faces + len(vertices), sampling, np.zeros((16, 16, 3)))


def test_the_grid_laplacian_is_the_four_neighbour_graphs():
    n = 5
    got = grid_laplacian(n).toarray()
    want = np.zeros((n * n, n * n))
    for i in range(n):
        for j in range(n):
            nbrs = [(a, b) for a, b in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1))]
            nbrs = [(a, b) for a, b in nbrs if 0 <= a < n and 0 <= b < n]
            want[i * n + j, i * n + j] = 1.0
            for a, b in nbrs:
                want[i * n + j, a * n + b] = -1.0 / len(nbrs)
    assert_allclose(got, want)


@pytest.mark.parametrize("n", [8, 16])
def test_a_fine_mesh_moved_through_the_grid_basis_fits_smoothly(curved_sheet, n):
    # 64 × 64 vertices on a 16² / 8² grid: 16 / 64 vertices per sample.  The unknowns are the
    # grid points' values, spread bilinearly: the move is the basis's (no vertex of its own),
    # fits the change, and is at least as smooth as the vertices' own least-norm move.
    vertices, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, n)
    changes = band_limited(n, np.random.default_rng(n), cycles=2)
    basis = bilinear_matrix(uv, n)
    grid = Transfer(faces, sampling, n_vertices=len(uv), energy="dirichlet", basis=basis)
    d = grid.apply(changes, passes=3)
    assert d.shape == vertices.shape
    assert relative_rms(sampling, d, changes) < 0.01
    assert np.abs(d).max() <= 1.1 * np.abs(changes).max()
    values = np.column_stack([lsqr(basis, d[:, k], atol=1e-14, btol=1e-14)[0] for k in range(3)])
    assert_allclose(basis @ values, d, atol=1e-9 * np.abs(d).max())
    own = Transfer(faces, sampling, n_vertices=len(uv), energy="dirichlet").apply(changes, passes=3)
    laplacian = uniform_laplacian(faces, len(uv))
    rough = [np.linalg.norm(laplacian @ x) / np.linalg.norm(x) for x in (d, own)]
    assert rough[0] <= 1.02 * rough[1]


def test_a_basis_of_another_grid_is_refused(curved_sheet):
    _, faces, uv = curved_sheet
    sampling = sampling_matrix(uv, faces, 16)
    with pytest.raises(ValueError, match="basis must be of the"):
        Transfer(faces, sampling, n_vertices=len(uv), basis=bilinear_matrix(uv, 8))
