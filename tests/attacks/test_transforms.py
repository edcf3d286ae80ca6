"""Tests for :mod:`meshwm.attacks.transforms`: pose, scale, order, formats, noise, crop."""

from __future__ import annotations

import tempfile

import numpy as np
import pytest
from _attack_checks import (
    _areas,
    _edge_lengths,
    _mean_centroid_distance,
    _same_mesh,
    _signed_volume,
    _square_fan,
)
from numpy.testing import assert_allclose, assert_array_equal
from scipy.optimize import linprog

from meshwm.attacks.transforms import (
    _random_rotation,
    crop,
    float32,
    mirror,
    noise,
    quantize,
    reorder,
    rotation,
    round_trip,
    scaling,
    similarity,
    translation,
)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_reorder_is_the_same_oriented_mesh(mesh, seed):
    v, f = mesh
    v2, f2 = reorder(v, f, seed=seed)
    assert not np.array_equal(v2, v)  # it did shuffle
    assert sorted(map(tuple, v2.tolist())) == sorted(map(tuple, v.tolist()))
    assert _same_mesh(v, f, v2, f2)


def test_same_mesh_helper_sees_a_flipped_face(mesh):
    """The comparison used above is not blind: one reversed face makes another mesh."""
    v, f = mesh
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    assert not _same_mesh(v, f, v, flipped)


@pytest.mark.parametrize("scale", [0.01, 1.0, 100.0])
def test_similarity_scales_every_edge_by_scale(mesh, scale):
    v, f = mesh
    v2, f2 = similarity(v, f, seed=5, scale=scale)
    assert_array_equal(f2, f)
    assert_allclose(_edge_lengths(v2, f) / _edge_lengths(v, f), scale, rtol=1e-9)
    # A rotation, not a reflection: the enclosed volume keeps its sign.
    assert_allclose(_signed_volume(v2, f), scale**3 * _signed_volume(v, f), rtol=1e-9)
    assert not np.allclose(v2, scale * v)  # it also rotated and moved the model


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_mirror_is_a_reflection_with_the_faces_turned_over(mesh, seed):
    v, f = mesh
    v2, f2 = mirror(v, f, seed=seed)
    assert_array_equal(f2, f[:, ::-1])
    ratio = _edge_lengths(v2, f) / _edge_lengths(v, f)
    assert_allclose(ratio, ratio[0], rtol=1e-9)
    # Reflected (the volume of the faces as they were turns negative), facing out again.
    assert _signed_volume(v2, f) * _signed_volume(v, f) < 0
    assert_allclose(_signed_volume(v2, f2), ratio[0] ** 3 * _signed_volume(v, f), rtol=1e-9)
    flip = np.ones(3)
    flip[seed % 3] = -1.0
    assert_allclose(v2, similarity(v * flip, f, seed=seed)[0], rtol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_similarity_default_scale_is_uniform_and_in_range(mesh, seed):
    v, f = mesh
    ratio = _edge_lengths(similarity(v, f, seed=seed)[0], f) / _edge_lengths(v, f)
    assert_allclose(ratio, ratio[0], rtol=1e-9)
    assert 0.01 <= ratio[0] <= 100


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rotation_is_a_seeded_rotation_about_the_centroid(mesh, seed):
    v, f = mesh
    v2, f2 = rotation(v, f, seed=seed)
    assert_array_equal(f2, f)  # connectivity kept
    centre = v.mean(axis=0)
    expected = (v - centre) @ _random_rotation(np.random.default_rng(seed)).T + centre
    assert_array_equal(v2, expected)  # exactly the helper similarity uses
    assert_allclose(v2.mean(axis=0), centre, rtol=0, atol=1e-12)
    assert_allclose(_edge_lengths(v2, f), _edge_lengths(v, f), rtol=1e-12)
    # A rotation, not a reflection: the enclosed volume keeps its sign.
    assert_allclose(_signed_volume(v2, f), _signed_volume(v, f), rtol=1e-12)
    assert not np.allclose(v2, v)
    assert_array_equal(rotation(v, f, seed=seed)[0], v2)
    assert not np.array_equal(rotation(v, f, seed=seed + 1)[0], v2)


def test_random_rotation_is_proper_and_orthogonal():
    for seed in range(20):
        r = _random_rotation(np.random.default_rng(seed))
        assert_allclose(r @ r.T, np.eye(3), rtol=0, atol=1e-12)
        assert_allclose(np.linalg.det(r), 1.0, rtol=1e-12)


@pytest.mark.parametrize("factor", [0.1, 2.0, 10.0])
def test_scaling_scales_about_the_centroid(mesh, factor):
    v, f = mesh
    v2, f2 = scaling(v, f, factor=factor)
    assert_array_equal(f2, f)  # connectivity kept
    centre = v.mean(axis=0)
    assert_array_equal(v2, (v - centre) * factor + centre)
    assert_allclose(v2.mean(axis=0), centre, rtol=0, atol=1e-12)
    assert_allclose(_edge_lengths(v2, f) / _edge_lengths(v, f), factor, rtol=1e-9)
    assert_array_equal(scaling(v, f, seed=7, factor=factor)[0], v2)  # seed ignored


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_translation_moves_every_vertex_by_the_same_seeded_vector(mesh, seed):
    v, f = mesh
    v2, f2 = translation(v, f, seed=seed, distance=3.0)
    assert_array_equal(f2, f)
    shift = v2 - v
    assert_allclose(shift, np.broadcast_to(shift[0], shift.shape), rtol=0, atol=1e-9)
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    assert_allclose(np.linalg.norm(shift[0]), 3.0 * diag, rtol=1e-12)
    assert_array_equal(translation(v, f, seed=seed, distance=3.0)[0], v2)
    assert not np.array_equal(translation(v, f, seed=seed + 1, distance=3.0)[0], v2)


def test_scaling_default_factor_is_two(mesh):
    v, f = mesh
    assert_array_equal(scaling(v, f)[0], scaling(v, f, factor=2.0)[0])
    assert_allclose(_edge_lengths(scaling(v, f)[0], f) / _edge_lengths(v, f), 2.0, rtol=1e-9)


@pytest.mark.parametrize("amplitude", [1e-4, 1e-3, 1e-2])
def test_noise_stays_within_its_amplitude(mesh, amplitude):
    v, f = mesh
    v2, f2 = noise(v, f, seed=6, amplitude=amplitude)
    assert_array_equal(f2, f)
    mean_dist = np.mean(np.linalg.norm(v - v.mean(axis=0), axis=1))
    delta = np.abs(v2 - v)
    bound = amplitude * mean_dist
    assert delta.max() <= bound * (1 + 1e-9)
    # Uniform in [-a, a]: thousands of coordinates come close to the bound, and the mean
    # |delta| is a / 2.
    assert delta.max() >= 0.99 * bound
    assert_allclose(delta.mean(), bound / 2, rtol=0.05)


def test_float32_rounds_to_single_precision(mesh):
    v, f = mesh
    v = v + 1e-9 * np.arange(v.size).reshape(v.shape)  # not representable in float32
    v2, f2 = float32(v, f)
    assert v2.dtype == np.float64
    assert_array_equal(v2, v.astype(np.float32).astype(np.float64))
    assert_array_equal(f2, f)
    assert not np.array_equal(v2, v)
    assert np.all(np.abs(v2 - v) <= np.abs(v) * 2.0**-24)
    assert_array_equal(float32(v2, f2)[0], v2)  # idempotent


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_indexed_round_trip_is_exact(mesh, suffix):
    v, f = mesh
    v = v + 1e-9 * np.arange(v.size).reshape(v.shape)  # full float64 precision
    v2, f2 = round_trip(v, f, suffix=suffix)
    assert_array_equal(v2, v)
    assert_array_equal(f2, f)


def test_stl_round_trip_is_float32_and_unindexed(mesh):
    v, f = mesh
    v2, f2 = round_trip(v, f, suffix=".stl")
    assert len(f2) == len(f)
    assert len(v2) == 3 * len(f)  # triangle soup
    as32 = v.astype(np.float32).astype(np.float64)
    assert np.all(np.abs(v2[f2] - v[f]) <= np.abs(v[f]) * 2.0**-24)
    assert _same_mesh(as32, f, v2, f2)


def test_round_trip_leaves_no_file(mesh, tmp_path, monkeypatch):
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(tempfile, "tempdir", None)
    round_trip(*mesh, suffix=".ply")
    assert list(tmp_path.iterdir()) == []


def test_noise_uses_the_mean_centroid_distance_of_the_mesh(mesh):
    v, f = mesh
    for a in (0.0005, 0.001, 0.003, 0.005):  # MEPP's 0.05, 0.1, 0.3, 0.5 %
        delta = np.abs(noise(v, f, seed=1, amplitude=a)[0] - v)
        assert delta.max() <= a * _mean_centroid_distance(v) * (1 + 1e-9)


@pytest.mark.parametrize("bits", [7, 9, 11, 16])
def test_quantize_snaps_to_2_to_the_bits_levels(mesh, bits):
    v, f = mesh
    q, f2 = quantize(v, f, bits=bits)
    assert_array_equal(f2, f)
    lo, hi = v.min(axis=0), v.max(axis=0)
    step = (hi - lo) / (2**bits - 1)
    for axis in range(3):
        assert len(np.unique(q[:, axis])) <= 2**bits
        levels = (q[:, axis] - lo[axis]) / step[axis]
        assert_allclose(levels, np.round(levels), rtol=0, atol=1e-6)
    assert np.all(np.abs(q - v) <= step / 2 * (1 + 1e-9))
    assert_allclose(q.min(axis=0), lo, rtol=0, atol=1e-12)
    assert_allclose(q.max(axis=0), hi, rtol=0, atol=1e-12)
    assert_array_equal(quantize(q, f, bits=bits)[0], q)  # idempotent


def test_quantize_leaves_a_flat_axis_alone():
    v, f = _square_fan()
    q = quantize(v, f, bits=7)[0]
    assert_array_equal(q[:, 2], 0.0)
    # 127 steps on [0, 2]: the ends are levels, the middle 1 rounds to level 64.
    assert_array_equal(np.unique(q[:, :2]), [0.0, 2 * 64 / 127, 2.0])


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("seed", [0, 1])
def test_crop_removes_the_fraction_of_the_area(mesh, fraction, seed):
    v, f = mesh
    v2, f2 = crop(v, f, seed=seed, fraction=fraction)
    removed = 1 - _areas(v2, f2).sum() / _areas(v, f).sum()
    assert abs(removed - fraction) <= 0.02
    assert np.array_equal(np.unique(f2), np.arange(len(v2)))  # no unreferenced vertex
    # What is left is a subset of the input: same positions, same triangles.
    kept = {tuple(map(tuple, v[t])) for t in f}
    assert all(tuple(map(tuple, v2[t])) in kept for t in f2)


@pytest.mark.parametrize("seed", [0, 3])
def test_crop_cuts_along_a_plane(mesh, seed):
    """Some plane has every removed face centroid strictly on one side and every kept one on
    the other (a feasibility linear program: w·c - b >= 1 removed, <= -1 kept)."""
    v, f = mesh
    v2, f2 = crop(v, f, seed=seed, fraction=0.3)
    kept_keys = {tuple(map(tuple, v2[t])) for t in f2}
    is_kept = np.array([tuple(map(tuple, v[t])) in kept_keys for t in f])
    assert 0 < (~is_kept).sum() < len(f)
    c = v[f].mean(axis=1)
    sign = np.where(is_kept, 1.0, -1.0)  # rows: sign * (w·c - b) <= -1
    a_ub = sign[:, None] * np.c_[c, -np.ones(len(c))]
    result = linprog(np.zeros(4), A_ub=a_ub, b_ub=-np.ones(len(c)), bounds=[(None, None)] * 4)
    assert result.status == 0, result.message
