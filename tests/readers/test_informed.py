"""The informed reader: references, sealed signatures, and copies told apart after attacks."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from meshwm.attacks import apply_attack
from meshwm.readers.informed import (
    Reference,
    copy_signature,
    correlate,
    faces_digest,
    highpass,
    host_changes,
    identify,
    make_reference,
    received_offsets,
    same_mesh_offsets,
    seal_signature,
    unseal_signature,
)
from meshwm.watermark import embed

IDS = ("0123456789abcdef", "fedcba9876543210")
#: z of a copy in a clean read after these attacks on spot is 10-40; an unmarked mesh's is
#: N(0, 1).  The tests ask for a wide margin either way.
PRESENT_Z = 6.0
ABSENT_Z = 4.5


@pytest.fixture(scope="module")
def spot_copies(spot_mesh):
    v, f = spot_mesh
    reference = make_reference(v, f, max_faces=10**6)
    copies = [embed(v, f, key="k", ident=bytes.fromhex(i), distances=False).vertices for i in IDS]
    host = host_changes(reference, v, f)
    signatures = [copy_signature(reference, c, f, host=host) for c in copies]
    return v, f, reference, copies, signatures


def test_reference_round_trip_is_exact(spot_copies):
    _, _, reference, _, _ = spot_copies
    back = Reference.from_bytes(reference.to_bytes())
    assert back.n == reference.n and back.diagonal == reference.diagonal
    assert np.array_equal(back.cells, reference.cells)
    assert np.array_equal(back.points, reference.points.astype(np.float32).astype(np.float64))
    assert np.allclose(back.normals, reference.normals, atol=1e-6)
    assert np.array_equal(back.anchors, reference.anchors.astype(np.float32).astype(np.float64))
    assert np.allclose(back.anchor_normals, reference.anchor_normals, atol=1e-3)
    assert back.vertices is not None and back.faces_digest == reference.faces_digest
    assert np.array_equal(back.vertices, reference.vertices.astype(np.float32).astype(np.float64))


def test_a_reference_without_the_asset_vertices_reads_and_does_not_apply(spot_copies):
    v, f, reference, copies, _ = spot_copies
    bare = make_reference(v, f, max_faces=10**6, snapshot=False)
    assert bare.vertices is None and bare.faces_digest is None
    back = Reference.from_bytes(bare.to_bytes())
    assert back.vertices is None and np.array_equal(back.cells, reference.cells)
    assert same_mesh_offsets(back, copies[0], f) is None


def test_the_vertex_reading_needs_the_same_faces(spot_copies):
    v, f, reference, copies, _ = spot_copies
    assert faces_digest(f) == faces_digest(f.astype(np.int32))
    assert same_mesh_offsets(reference, copies[0], f[::-1]) is None  # faces reordered
    assert same_mesh_offsets(reference, copies[0][:-1], f[f.max(axis=1) < len(v) - 1]) is None
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    assert same_mesh_offsets(reference, copies[0], flipped) is None
    assert same_mesh_offsets(reference, copies[0], f) is not None


@pytest.mark.parametrize(
    ("attack", "options"),
    [
        ("meshlab_laplacian", {"iterations": 3}),
        ("taubin", {}),
        ("laplacian", {"iterations": 30}),
        ("noise", {"amplitude": 0.003}),
        ("quantize", {"bits": 9}),
    ],
)
@pytest.mark.parametrize("which", [0, 1])
def test_the_vertex_reading_tells_copies_apart_after_smoothing(spot_copies, attack, options, which):
    v, f, reference, copies, signatures = spot_copies
    vv, ff = apply_attack("similarity", copies[which], f, seed=3)
    vv, ff = apply_attack(attack, vv, ff, seed=1, **options)
    offsets = same_mesh_offsets(reference, vv, ff)
    assert offsets is not None
    best, score, versus = identify(offsets, signatures, reference)
    assert best == which and score.z > PRESENT_Z and versus is not None and versus.z > PRESENT_Z
    unmarked = apply_attack(attack, *apply_attack("similarity", v, f, seed=3), seed=1, **options)
    offsets = same_mesh_offsets(reference, *unmarked)
    assert offsets is not None
    assert max(correlate(offsets, s, reference).z for s in signatures) < ABSENT_Z


def test_the_vertex_reading_does_not_move_under_similarities(spot_copies):
    """20 random similarities (scale 0.01-100, translation ±100) give the same offsets."""
    _, f, reference, copies, _ = spot_copies
    base = same_mesh_offsets(reference, copies[0], f)
    assert base is not None
    rng = np.random.default_rng(20)
    for _ in range(20):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        q *= np.sign(np.linalg.det(q))
        moved = 10 ** rng.uniform(-2, 2) * copies[0] @ q.T + rng.uniform(-100, 100, 3)
        again = same_mesh_offsets(reference, moved, f)
        assert again is not None
        assert np.nanmax(np.abs(again - base)) < 1e-9 * reference.diagonal


def test_a_signature_carries_nothing_of_the_host_smoothing(spot_copies):
    """The host's own smoothing directions are projected out: the unmarked asset smoothed
    those ways does not correlate with any copy, and the signatures keep the marks."""
    v, f, reference, copies, signatures = spot_copies
    host = host_changes(reference, v, f)
    assert host.shape == (len(reference.cells), 3) and np.abs(host).max() > 0
    for sig in signatures:
        for column in host.T:
            assert abs(correlate(column, sig, reference).z) < 1.0
    raw = [copy_signature(reference, c, f) for c in copies]
    for r, sig in zip(raw, signatures, strict=True):
        assert np.corrcoef(highpass(r, reference), highpass(sig, reference))[0, 1] > 0.9


@pytest.mark.parametrize("data", [b"", b"not a reference", b"PK\x03\x04" + bytes(40)])
def test_reference_from_garbage_is_refused(data):
    with pytest.raises(ValueError, match="not a reference"):
        Reference.from_bytes(data)


def test_signature_unseals_only_with_the_key(spot_copies):
    _, _, reference, _, signatures = spot_copies
    sig = signatures[0].astype(np.float64)
    blob = seal_signature(sig, reference, key="k")
    assert b"k" * 4 not in blob
    back = unseal_signature(blob, reference, key="k")
    assert np.allclose(back, sig, atol=1e-3 * np.abs(sig).max())
    wrong = unseal_signature(blob, reference, key="another key")
    assert abs(np.corrcoef(wrong, sig)[0, 1]) < 0.05
    with pytest.raises(ValueError, match="does not fit"):
        unseal_signature(blob[:-2], reference, key="k")


def test_unmarked_mesh_offsets_are_zero(spot_copies):
    v, f, reference, _, _ = spot_copies
    h = received_offsets(reference, v, f)
    assert np.all(np.isfinite(h))
    assert np.abs(h).max() < 1e-9 * reference.diagonal


ATTACKS = [
    ("none", {}),
    ("simplify", {"keep_fraction": 0.5}),
    ("subdivide_midpoint", {}),
    ("subdivide_loop", {}),
    ("remesh_isotropic", {}),
    ("noise", {"amplitude": 0.001}),
    ("crop", {"fraction": 0.3}),
]


@pytest.mark.slow
@pytest.mark.parametrize(("attack", "options"), ATTACKS)
@pytest.mark.parametrize("which", [0, 1])
def test_copies_are_told_apart_after_attacks(spot_copies, attack, options, which):
    """The right copy wins, significantly, and against the other copy's signature too."""
    _v, f, reference, copies, signatures = spot_copies
    if attack == "none":
        vv, ff = copies[which], f
    else:
        vv, ff = apply_attack(attack, copies[which], f, seed=3, **options)
    h = received_offsets(reference, vv, ff)
    best, score, versus = identify(h, signatures, reference)
    assert best == which
    assert score.z > PRESENT_Z and versus is not None and versus.z > PRESENT_Z / 2
    assert score.decoys > 10_000


@pytest.mark.parametrize("attack", ["none", "simplify", "remesh_isotropic"])
def test_unmarked_mesh_does_not_correlate(spot_copies, attack):
    v, f, reference, _, signatures = spot_copies
    vv, ff = (v, f) if attack == "none" else apply_attack(attack, v, f, seed=1)
    h = received_offsets(reference, vv, ff)
    for sig in signatures:
        assert correlate(h, sig, reference).z < ABSENT_Z


def test_z_is_standard_normal_under_the_null(spot_copies):
    """Smooth random fields (the offsets' kind of noise) against a signature: z ~ N(0, 1)."""
    from scipy import ndimage

    _, _, reference, _, signatures = spot_copies
    zs = []
    for trial in range(200):
        seed = int.from_bytes(hashlib.sha256(f"null/{trial}".encode()).digest()[:8], "little")
        field = np.random.default_rng(seed).standard_normal((reference.n, reference.n))
        field = ndimage.gaussian_filter(field, 1.5, mode="wrap").ravel()[reference.cells]
        zs.append(correlate(field, signatures[trial % 2], reference).z)
    zs = np.array(zs)
    assert abs(zs.mean()) < 0.3 and 0.75 < zs.std() < 1.3
    assert np.abs(zs).max() < 4.5


def test_cropped_away_points_are_missing(spot_copies):
    _v, f, reference, copies, _ = spot_copies
    vv, ff = apply_attack("crop", copies[0], f, seed=1, fraction=0.3)
    h = received_offsets(reference, vv, ff)
    assert 0.4 < np.isfinite(h).mean() < 0.95


def test_identify_needs_signatures(spot_copies):
    _, _, reference, _, _ = spot_copies
    with pytest.raises(ValueError, match="no signatures"):
        identify(np.zeros(len(reference.cells)), [], reference)
