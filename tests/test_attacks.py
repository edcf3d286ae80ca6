"""Tests for :mod:`meshwm.attacks`: seeded, pure attacks that keep the connectivity."""

from __future__ import annotations

import re
import tempfile

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from meshwm.attacks import ATTACKS, apply_attack, float32, noise, reorder, round_trip, similarity

RANDOM = ["similarity", "reorder", "noise"]
SEEDLESS = ["float32", "round_trip"]


def _oriented_faces(v: np.ndarray, f: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The faces as sorted rows of position ids, each rotated to start at its smallest id.

    Two meshes that are the same up to vertex order, face order and cyclic rotation of corners
    give the same array (orientation is kept: a reversed face gives another row).
    """
    ids = np.unique(positions, axis=0, return_inverse=True)[1].ravel()
    lookup = {tuple(p): i for p, i in zip(positions.tolist(), ids.tolist(), strict=True)}
    fid = np.array([lookup[tuple(p)] for p in v.tolist()])[f]
    start = np.argmin(fid, axis=1)
    fid = np.take_along_axis(fid, (start[:, None] + np.arange(3)) % 3, axis=1)
    return fid[np.lexsort(fid.T[::-1])]


def _same_mesh(v1, f1, v2, f2) -> bool:
    both = np.vstack([v1, v2])
    return np.array_equal(_oriented_faces(v1, f1, both), _oriented_faces(v2, f2, both))


def _edge_lengths(v, f) -> np.ndarray:
    return np.linalg.norm(v[f] - v[np.roll(f, -1, axis=1)], axis=-1).ravel()


def _signed_volume(v, f) -> float:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6)


@pytest.fixture(scope="module")
def mesh(spot_mesh):
    return spot_mesh


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_is_deterministic_for_a_seed(mesh, name):
    v1, f1 = apply_attack(name, *mesh, seed=11)
    v2, f2 = apply_attack(name, *mesh, seed=11)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", RANDOM)
def test_random_attack_changes_with_the_seed(mesh, name):
    v1, f1 = apply_attack(name, *mesh, seed=1)
    v2, f2 = apply_attack(name, *mesh, seed=2)
    assert not (np.array_equal(v1, v2) and np.array_equal(f1, f2))


@pytest.mark.parametrize("name", SEEDLESS)
def test_seedless_attack_ignores_the_seed(mesh, name):
    v1, f1 = apply_attack(name, *mesh, seed=1)
    v2, f2 = apply_attack(name, *mesh, seed=2)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_leaves_its_input_alone(mesh, name):
    v, f = mesh[0].copy(), mesh[1].copy()
    out_v, out_f = apply_attack(name, v, f, seed=4)
    assert_array_equal(v, mesh[0])
    assert_array_equal(f, mesh[1])
    assert out_v.dtype == np.float64 and out_v.shape[1] == 3
    assert out_f.shape[1] == 3 and np.issubdtype(out_f.dtype, np.integer)


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


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_similarity_default_scale_is_uniform_and_in_range(mesh, seed):
    v, f = mesh
    ratio = _edge_lengths(similarity(v, f, seed=seed)[0], f) / _edge_lengths(v, f)
    assert_allclose(ratio, ratio[0], rtol=1e-9)
    assert 0.01 <= ratio[0] <= 100


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


def test_apply_attack_passes_options(mesh):
    v1, f1 = apply_attack("similarity", *mesh, seed=9, scale=3.0)
    v2, f2 = similarity(*mesh, seed=9, scale=3.0)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


def test_unknown_attack_lists_the_valid_names(mesh):
    with pytest.raises(ValueError, match="unknown attack 'smooth'") as info:
        apply_attack("smooth", *mesh)
    assert re.search(re.escape(", ".join(sorted(ATTACKS))), str(info.value))
    for name in ATTACKS:
        assert name in str(info.value)


def test_registry_names_its_functions():
    assert ATTACKS["similarity"] is similarity
    assert set(ATTACKS) == {"similarity", "reorder", "noise", "float32", "round_trip"}
