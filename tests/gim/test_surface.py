"""The mesh as a sampled surface: reusing a map where it is provably the same."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.gim.stable import nudge_start, smoothed_copy
from meshwm.gim.surface import (
    SURFACE_RANKS,
    _filled,
    keep_start,
    remap_surface,
    sample_surface,
    surface_of,
)


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.map.uv, b.map.uv)
    np.testing.assert_array_equal(a.map.cut.edges, b.map.cut.edges)
    np.testing.assert_array_equal(a.map.cut.order, b.map.cut.order)
    np.testing.assert_array_equal(a.map.cut.mesh.vertices, b.map.cut.mesh.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert a.map.cut.near_ties == b.map.cut.near_ties
    ia, ib = sample_surface(a, size=128), sample_surface(b, size=128)
    np.testing.assert_array_equal(ia.samples, ib.samples)


@pytest.mark.parametrize("name", ["spot_mesh", "kitten_mesh", "plane_mesh"])
def test_a_map_passed_as_like_changes_nothing(request, name):
    v, f = request.getfixturevalue(name)
    base = surface_of(v, f)
    rng = np.random.default_rng(5)
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    for k in range(4):
        if k < 3:  # a mark-sized move of the distinct positions (copies move together)
            moved = base.positions + rng.normal(size=base.positions.shape) * 2e-4 * diag
            w = moved[base.inverse]
        else:  # a large move: the start changes and the map is made anew
            w = v * np.array([1.0, 3.0, 0.2])
        _same(surface_of(w, f, like=base), surface_of(w, f))


def test_like_of_another_mesh_is_not_used(spot_mesh, kitten_mesh):
    v, f = kitten_mesh
    other = surface_of(*spot_mesh)
    _same(surface_of(v, f, like=other), surface_of(v, f))
    perm = np.random.default_rng(2).permutation(len(v))  # reordered: other inverse, no reuse
    back = np.argsort(perm)
    _same(surface_of(v[perm], back[f], like=surface_of(v, f)), surface_of(v[perm], back[f]))


@pytest.mark.parametrize("name", ["spot_mesh", "kitten_mesh"])
def test_a_map_passed_to_remap_changes_nothing_at_any_rank(request, name):
    # The read-back asks the input's map for every start a reader offers: reused where that
    # start is the input's, made anew elsewhere; bit for bit the map made without it.
    v, f = request.getfixturevalue(name)
    base = surface_of(v, f)
    rng = np.random.default_rng(11)
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    reused = 0
    for _ in range(3):
        moved = base.positions + rng.normal(size=base.positions.shape) * 2e-4 * diag
        received = surface_of(moved[base.inverse], f)
        for rank in SURFACE_RANKS[:3]:
            hinted = remap_surface(received, moved, rank=rank, like=base.map)
            fresh = remap_surface(received, moved, rank=rank)
            _same(hinted, fresh)
            reused += hinted.map.uv is base.map.uv
    assert reused >= 3  # the input's own start, at least (rank 0 after a mark-sized move)


def _start(surface):
    return tuple(int(x) for x in surface.map.cut.order[:2])


@pytest.mark.parametrize("name", ["spot_mesh", "plane_mesh"])
def test_keep_start_puts_a_tipped_start_back_with_a_small_smooth_bump(request, name):
    v, f = request.getfixturevalue(name)
    base = surface_of(v, f)
    diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
    # The input's own start: nothing to add.
    assert not keep_start(base, np.zeros_like(base.positions)).any()
    k = len(base.clean_to_position)
    cut = base.map.cut
    filled = cut.mesh.origin[cut.mesh.faces]
    points, faces = _filled(base.positions[base.clean_to_position], filled[(filled < k).all(1)])
    np.testing.assert_array_equal(faces, filled)
    smooth = smoothed_copy(points, faces)
    radial = np.linalg.norm(smooth - smooth.mean(axis=0), axis=1)
    rng = np.random.default_rng(3)
    tipped = 0
    for rival in rng.choice(np.argsort(-radial)[1:12], size=3, replace=False):
        # Tip the start to another vertex near the top, as a mark can.
        tip = nudge_start(points, faces, int(rival), margin=1e-5)
        if tip is None:
            continue
        moved = base.positions.copy()
        moved[base.clean_to_position] += tip[:k]
        moved_start = _start(surface_of(moved[base.inverse], f))
        assert moved_start != _start(base)
        d = moved - base.positions
        bump = keep_start(base, d)
        assert bump is not None
        assert _start(surface_of((base.positions + (d + bump))[base.inverse], f)) == _start(base)
        assert np.abs(bump).max() <= 2 * np.abs(tip).max() + 1e-3 * diag
        tipped += 1
    assert tipped >= 2


@pytest.mark.parametrize("name", ["spot_mesh", "plane_mesh"])
def test_the_surface_basis_puts_each_position_at_its_uv(request, name):
    from meshwm.gim.sampling import grid_points
    from meshwm.gim.surface import surface_basis

    v, f = request.getfixturevalue(name)
    surface = surface_of(v, f)
    n = 64
    basis = surface_basis(surface, size=n)
    assert basis.shape == (len(surface.positions), n * n)
    sums = np.asarray(basis.sum(axis=1)).ravel()
    mapped = np.zeros(len(surface.positions), dtype=bool)
    mapped[surface.clean_to_position] = True
    np.testing.assert_allclose(sums[mapped], 1.0)
    assert not sums[~mapped].any()
    # A linear field on the grid comes back as the position's UV (the mean of its copies' on
    # the cut's two sides).
    cut = surface.map.cut.mesh
    real = cut.origin < len(surface.clean_to_position)
    position = surface.clean_to_position[cut.origin[real]]
    want = np.zeros((len(surface.positions), 2))
    np.add.at(want, position, surface.map.uv[real])
    want[mapped] /= np.bincount(position, minlength=len(want))[mapped, None]
    np.testing.assert_allclose(basis @ grid_points(n), want, atol=1e-12)


def test_a_sampling_is_reused_for_the_same_map_only(spot_mesh, kitten_mesh):
    # The embedder's read-back samples the map it reused again: the memoised matrix is the one
    # a fresh sampling gives, whatever a caller did to the copy it was handed, and another
    # map gets its own.
    from meshwm.gim.surface import _sampling_of

    v, f = spot_mesh
    base = surface_of(v, f)
    moved = base.positions + np.random.default_rng(3).normal(size=base.positions.shape) * 1e-4
    again = surface_of(moved[base.inverse], f, like=base)
    assert again.map is base.map or np.array_equal(again.map.uv, base.map.uv)
    first = sample_surface(base, size=64)
    first.matrix.data[:] = 0.0  # a caller scribbling on its copy
    first.covered[:] = False
    second = sample_surface(again, size=64)
    fresh, covered = _sampling_of(again, 64)
    assert (second.matrix != fresh).nnz == 0 and second.matrix.nnz == fresh.nnz > 0
    np.testing.assert_array_equal(second.covered, covered)
    np.testing.assert_array_equal(
        second.samples[covered], np.asarray(fresh @ moved)[covered.ravel()]
    )
    other = surface_of(*kitten_mesh)
    mat, cov = _sampling_of(other, 64)
    got = sample_surface(other, size=64)
    assert (got.matrix != mat).nnz == 0 and got.matrix.shape != second.matrix.shape
    np.testing.assert_array_equal(got.covered, cov)
