"""Tests for ``scripts/cho2007.py``: the Cho, Prost & Jung 2007 baseline (method I)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))

from cho2007 import (
    bin_statistics,
    calibrate_cho,
    cho_reads_id,
    embed_cho,
    extract_cho,
    id_bits,
    mrms_rel,
)

from meshwm.message.payload import parse_id

KEY = "cho-test"


def _blob(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere with a smooth radial bump (norms spread over about [0.5, 1.5])."""
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    v = np.asarray(sphere.vertices, dtype=np.float64)
    x, y, z = v.T
    v = v * (1 + 0.3 * np.sin(2 * x + 1) * np.cos(3 * y) + 0.2 * z**2)[:, None]
    return v, np.asarray(sphere.faces, dtype=np.int64)


@pytest.fixture(scope="module")
def blob() -> tuple[np.ndarray, np.ndarray]:
    """2,562 vertices: 64 bins of about 40 vertices."""
    return _blob(4)


@pytest.fixture(scope="module")
def bits() -> np.ndarray:
    return np.random.default_rng(7).integers(0, 2, 64).astype(np.uint8)


@pytest.fixture(scope="module")
def marked(blob, bits) -> np.ndarray:
    v, f = blob
    return embed_cho(v, f, bits, key=KEY, alpha=0.05)


def test_round_trip_reads_every_bit(blob, bits, marked):
    v, f = blob
    assert marked.shape == v.shape
    assert not np.array_equal(marked, v)
    np.testing.assert_array_equal(extract_cho(marked, f, len(bits), key=KEY), bits)


def test_embedding_moves_vertices_along_their_direction_from_the_centre(blob, marked):
    v, _ = blob
    c = v.mean(axis=0)
    u, w = v - c, marked - c
    cos = np.sum(u * w, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))
    assert cos.min() > 1 - 1e-6  # the centre moves a little; directions stay put


def test_bin_means_reach_the_strength(blob, bits, marked):
    _, f = blob
    stats = bin_statistics(marked, f, len(bits))
    margin = np.abs(stats.means[stats.counts > 0] - 0.5)
    assert np.median(margin) > 0.045


def test_similarity_reads_every_bit(blob, bits, marked):
    _, f = blob
    angle = 0.7
    rot = trimesh.transformations.rotation_matrix(angle, [1, 2, 3])[:3, :3]
    moved = 3.7 * marked @ rot.T + np.array([10.0, -4.0, 2.5])
    np.testing.assert_array_equal(extract_cho(moved, f, len(bits), key=KEY), bits)


def test_reordered_vertices_read_every_bit(blob, bits, marked):
    _, f = blob
    order = np.random.default_rng(3).permutation(len(marked))
    inverse = np.argsort(order)
    got = extract_cho(marked[order], inverse[f], len(bits), key=KEY)
    np.testing.assert_array_equal(got, bits)


def test_wrong_key_reads_about_half(blob, bits, marked):
    _, f = blob
    errors = [np.mean(extract_cho(marked, f, len(bits), key=f"other{i}") != bits) for i in range(8)]
    assert 0.35 < np.mean(errors) < 0.65


def test_unmarked_mesh_reads_about_half(blob, bits):
    v, f = blob
    assert 0.25 < np.mean(extract_cho(v, f, len(bits), key=KEY) != bits) < 0.75


def test_calibrate_hits_the_target_mrms(blob, bits):
    v, f = blob
    out, alpha = calibrate_cho(v, f, bits, key=KEY, target_mrms_rel=2e-4, samples=50_000)
    assert 0 < alpha < 0.5
    assert abs(mrms_rel(v, f, out, f, samples=50_000) / 2e-4 - 1) < 0.1
    np.testing.assert_array_equal(out, embed_cho(v, f, bits, key=KEY, alpha=alpha))
    np.testing.assert_array_equal(extract_cho(out, f, len(bits), key=KEY), bits)


def test_cho_reads_id_raw(blob):
    v, f = blob
    ident = parse_id("1234abcd")
    raw = embed_cho(v, f, id_bits(ident, raw=True), key=KEY, alpha=0.05)
    assert cho_reads_id(raw, f, ident, key=KEY, raw=True)
    assert not cho_reads_id(raw, f, parse_id("1234abce"), key=KEY, raw=True)


def test_cho_reads_id_coded():
    # 256 bins want more vertices: on the 2,562-vertex blob 35 bins are empty.
    v, f = _blob(5)
    ident = parse_id("1234abcd")
    coded = embed_cho(v, f, id_bits(ident), key=KEY, alpha=0.1)
    assert id_bits(ident).shape == (256,)
    assert cho_reads_id(coded, f, ident, key=KEY)
    assert not cho_reads_id(coded, f, ident, key="not the key")


def test_surface_centre_round_trip(blob, bits):
    v, f = blob
    out = embed_cho(v, f, bits, key=KEY, alpha=0.05, centre="surface")
    np.testing.assert_array_equal(extract_cho(out, f, len(bits), key=KEY, centre="surface"), bits)


def test_inputs_are_not_modified(blob, bits):
    v, f = blob
    v0, f0 = v.copy(), f.copy()
    embed_cho(v, f, bits, key=KEY, alpha=0.05)
    np.testing.assert_array_equal(v, v0)
    np.testing.assert_array_equal(f, f0)


@pytest.mark.parametrize(
    ("options", "word"),
    [
        ({"alpha": 0.0}, "alpha"),
        ({"alpha": 0.5}, "alpha"),
        ({"alpha": 0.1, "passes": 0}, "passes"),
        ({"alpha": 0.1, "centre": "middle"}, "centre"),
    ],
)
def test_bad_options_name_the_parameter(blob, bits, options, word):
    v, f = blob
    with pytest.raises(ValueError, match=word):
        embed_cho(v, f, bits, key=KEY, **options)


def test_bad_bits_are_refused(blob):
    v, f = blob
    with pytest.raises(ValueError, match="bits"):
        embed_cho(v, f, np.array([0, 2, 1]), key=KEY, alpha=0.1)
