"""Tests for :mod:`meshwm.attacks.library`: seeded, pure attacks and the ``meshwm attack`` command.

Mesh attacks run on the bundled spot mesh; the paper's ``gim_*`` attacks on a meshwm geometry-
image mesh of it at N = 64 (``geometry_image_to_mesh(gim, weld)``).
"""

from __future__ import annotations

import inspect
import itertools
import json
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from numpy.testing import assert_allclose, assert_array_equal
from scipy.ndimage import correlate
from scipy.optimize import linprog

from meshwm.apps.cli import main
from meshwm.attacks.library import (
    ATTACK_PARAMS,
    ATTACKS,
    AttackParam,
    apply_attack,
    crop,
    float32,
    fspecial_gaussian,
    fspecial_laplacian,
    fspecial_log,
    gim_crop,
    gim_gaussian,
    gim_laplacian,
    gim_log,
    gim_noise,
    gim_salt_pepper,
    laplacian,
    meshlab_laplacian,
    noise,
    quantize,
    reorder,
    round_trip,
    similarity,
    simplify,
    subdivide_loop,
    subdivide_midpoint,
    taubin,
)
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import unique_edges
from meshwm.mesh.io import read_mesh, write_mesh

RANDOM = ["similarity", "reorder", "noise", "crop", "gim_salt_pepper", "gim_noise", "gim_crop"]
SEEDLESS = sorted(set(ATTACKS) - set(RANDOM))
GIM = sorted(name for name in ATTACKS if name.startswith("gim_"))
#: Attacks that keep the vertex count and the face list as they are.
SAME_FACES = ["similarity", "noise", "float32", "laplacian", "meshlab_laplacian", "taubin"]
SAME_FACES += ["quantize", *GIM]


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


def _areas(v, f) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def _roughness(v, f) -> float:
    """Mean length of the uniform umbrella vector (mean of the neighbours minus the vertex)."""
    edges, _ = unique_edges(f)
    n = len(v)
    rows, cols = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
    adjacency = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return float(np.mean(np.linalg.norm(adjacency @ v / degree[:, None] - v, axis=1)))


def _mean_centroid_distance(v) -> float:
    return float(np.mean(np.linalg.norm(v - v.mean(axis=0), axis=1)))


@pytest.fixture(scope="module")
def mesh(spot_mesh):
    return spot_mesh


@pytest.fixture(scope="module")
def gim_mesh(spot_mesh):
    """A geometry-image mesh as meshwm writes it (N = 64, cut seams welded)."""
    g = mesh_to_geometry_image(*spot_mesh, size=64)
    return geometry_image_to_mesh(g.gim, g.weld)


@pytest.fixture(scope="module")
def meshes(mesh, gim_mesh):
    """The input each attack is tested on."""
    return {name: gim_mesh if name in GIM else mesh for name in ATTACKS}


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_is_deterministic_for_a_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=11)
    v2, f2 = apply_attack(name, *meshes[name], seed=11)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", RANDOM)
def test_random_attack_changes_with_the_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=1)
    v2, f2 = apply_attack(name, *meshes[name], seed=2)
    assert not (np.array_equal(v1, v2) and np.array_equal(f1, f2))


@pytest.mark.parametrize("name", SEEDLESS)
def test_seedless_attack_ignores_the_seed(meshes, name):
    v1, f1 = apply_attack(name, *meshes[name], seed=1)
    v2, f2 = apply_attack(name, *meshes[name], seed=2)
    assert_array_equal(v1, v2)
    assert_array_equal(f1, f2)


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_attack_leaves_its_input_alone(meshes, name):
    v0, f0 = meshes[name]
    v, f = v0.copy(), f0.copy()
    out_v, out_f = apply_attack(name, v, f, seed=4)
    assert_array_equal(v, v0)
    assert_array_equal(f, f0)
    assert out_v.dtype == np.float64 and out_v.shape[1] == 3
    assert out_f.dtype == np.int64 and out_f.shape[1] == 3
    assert out_f.min() >= 0 and out_f.max() < len(out_v)
    assert np.all(np.isfinite(out_v))


@pytest.mark.parametrize("name", sorted(set(ATTACKS) - {"reorder", "float32", "round_trip"}))
def test_attack_changes_the_geometry(meshes, name):
    v, f = meshes[name]
    v2, _ = apply_attack(name, v, f, seed=4)
    assert v2.shape != v.shape or not np.allclose(v2, v, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", SAME_FACES)
def test_attack_keeps_the_connectivity(meshes, name):
    v, f = meshes[name]
    v2, f2 = apply_attack(name, v, f, seed=4)
    assert v2.shape == v.shape
    assert_array_equal(f2, f)


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
    assert set(ATTACKS) == {
        *("similarity", "reorder", "noise", "float32", "round_trip"),
        *("laplacian", "meshlab_laplacian", "taubin", "quantize", "crop", "simplify"),
        *("subdivide_midpoint", "subdivide_loop"),
        *("gim_gaussian", "gim_log", "gim_laplacian", "gim_salt_pepper", "gim_noise", "gim_crop"),
    }
    for name, attack in ATTACKS.items():
        assert attack.__name__ == name


# --- the parameter registry ------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_params_describe_the_signature(name):
    """ATTACK_PARAMS lists exactly the keyword options of each attack, with its defaults."""
    signature = inspect.signature(ATTACKS[name])
    options = {
        p.name: p.default
        for p in signature.parameters.values()
        if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name != "seed"
    }
    assert signature.parameters["seed"].default == 0
    spec = ATTACK_PARAMS[name]
    assert [p.name for p in spec] == list(options)
    for p in spec:
        assert p.default == options[p.name]
        assert p.meaning
        if p.default is not None:
            assert p.check(p.default, name) == p.default


BAD_VALUES = [
    ("similarity", {"scale": 0.0}, r"scale must be a number > 0"),
    ("noise", {"amplitude": 2.0}, r"amplitude must be a number in \(0, 1\]"),
    ("round_trip", {"suffix": ".off"}, r"suffix must be one of \.obj, \.ply, \.stl"),
    ("laplacian", {"lam": 0.0}, r"lam must be a number in \(0, 1\], got 0\.0"),
    ("laplacian", {"iterations": 0}, r"iterations must be an integer in 1\.\.1000"),
    ("meshlab_laplacian", {"iterations": 1001}, r"iterations must be an integer in 1\.\.1000"),
    ("taubin", {"mu": 0.0}, r"mu must be a number in \[-1, 0\)"),
    ("quantize", {"bits": 6}, r"bits must be an integer in 7\.\.16, got 6"),
    ("quantize", {"bits": 17}, r"bits must be an integer in 7\.\.16"),
    ("crop", {"fraction": 1.0}, r"fraction must be a number in \(0, 1\)"),
    ("simplify", {"keep_fraction": 0.0}, r"keep_fraction must be a number in \(0, 1\)"),
    ("subdivide_loop", {"iterations": 4}, r"iterations must be an integer in 1\.\.3"),
    ("gim_gaussian", {"hsize": 4}, r"hsize must be an odd integer in 3\.\.31, got 4"),
    ("gim_gaussian", {"sigma": -1.0}, r"sigma must be a number in \(0, 100\]"),
    ("gim_log", {"sigma": float("nan")}, r"sigma must be a number in \(0, 10\]"),
    ("gim_laplacian", {"alpha": 1.5}, r"alpha must be a number in \[0, 1\]"),
    ("gim_salt_pepper", {"density": 0.0}, r"density must be a number in \(0, 1\]"),
    ("gim_noise", {"amplitude": float("inf")}, r"amplitude must be a number in \(0, 1\]"),
    ("gim_crop", {"fraction": 0.0}, r"fraction must be a number in \(0, 1\)"),
]


@pytest.mark.parametrize(
    ("name", "options", "match"), BAD_VALUES, ids=[f"{n}-{o}" for n, o, _ in BAD_VALUES]
)
def test_bad_parameter_value_raises(mesh, name, options, match):
    """The value is checked before the mesh is looked at (gim attacks on spot included)."""
    with pytest.raises(ValueError, match=f"^{name}: {match}"):
        apply_attack(name, *mesh, **options)
    with pytest.raises(ValueError, match=match):
        ATTACKS[name](*mesh, **options)


@pytest.mark.parametrize(
    ("name", "options"),
    [("quantize", {"bits": 9.0}), ("laplacian", {"iterations": True}), ("crop", {"fraction": "1"})],
)
def test_wrong_parameter_type_raises(mesh, name, options):
    with pytest.raises(TypeError, match=f"{name}: {next(iter(options))} must be"):
        apply_attack(name, *mesh, **options)


def test_unknown_option_lists_the_valid_ones(mesh):
    with pytest.raises(ValueError, match=r"laplacian: unknown option 'bits'; valid: seed, lam, "):
        apply_attack("laplacian", *mesh, bits=9)


def test_param_parses_command_line_text():
    bits = ATTACK_PARAMS["quantize"][0]
    assert bits.parse("10", "quantize") == 10
    with pytest.raises(
        ValueError, match=r"quantize: bits must be an integer in 7\.\.16, got '9\.5'"
    ):
        bits.parse("9.5", "quantize")
    assert ATTACK_PARAMS["taubin"][1].parse("-0.6", "taubin") == -0.6
    assert AttackParam("x", float, 1.0, "m", low=0).allowed == "a number >= 0"


# --- mesh attacks ----------------------------------------------------------------------------


def test_noise_uses_the_mean_centroid_distance_of_the_mesh(mesh):
    v, f = mesh
    for a in (0.0005, 0.001, 0.003, 0.005):  # MEPP's 0.05, 0.1, 0.3, 0.5 %
        delta = np.abs(noise(v, f, seed=1, amplitude=a)[0] - v)
        assert delta.max() <= a * _mean_centroid_distance(v) * (1 + 1e-9)


def _square_fan():
    """A flat 3×3 grid of vertices (spacing 1, centre 4) in 8 triangles: one interior vertex."""
    i, j = np.divmod(np.arange(9), 3)
    v = np.stack([j, i, np.zeros(9)], axis=1).astype(float)
    f = []
    for r in range(2):
        for c in range(2):
            p = 3 * r + c
            f += [[p, p + 1, p + 4], [p, p + 4, p + 3]]
    return v, np.array(f)


def test_laplacian_step_by_hand():
    """λ = 1, one step: the interior vertex goes to the mean of its 6 neighbours; a border
    vertex to the mean of its 2 neighbours along the border (not its interior neighbours)."""
    v, f = _square_fan()
    v[4, 2] = 1.0  # lift the centre
    v[1, 2] = 0.5  # and a border midpoint
    out, out_f = laplacian(v, f, lam=1.0, iterations=1)
    assert_array_equal(out_f, f)
    ring = [v[k] for k in (0, 1, 3, 5, 7, 8)]  # neighbours of 4 by the diagonals chosen
    assert_allclose(out[4], np.mean(ring, axis=0), rtol=0, atol=1e-12)
    assert_allclose(out[1], (v[0] + v[2]) / 2, rtol=0, atol=1e-12)  # centre ignored
    assert_allclose(out[0], (v[1] + v[3]) / 2, rtol=0, atol=1e-12)
    half = laplacian(v, f, lam=0.5, iterations=1)[0]
    assert_allclose(half, (v + out) / 2, rtol=0, atol=1e-12)


def test_laplacian_smooths_more_with_more_iterations(mesh):
    v, f = mesh
    rough = [_roughness(v, f)]
    rough += [_roughness(laplacian(v, f, iterations=k)[0], f) for k in (5, 10, 30, 50)]
    assert all(a > b for a, b in itertools.pairwise(rough))
    assert rough[-1] < 0.6 * rough[0]


@pytest.mark.parametrize("attack", [laplacian, meshlab_laplacian, taubin])
def test_smoothing_reduces_roughness_and_stays_close(mesh, attack):
    v, f = mesh
    v2, f2 = attack(v, f)
    assert_array_equal(f2, f)
    assert _roughness(v2, f) < 0.95 * _roughness(v, f)
    assert np.linalg.norm(v2 - v, axis=1).max() < 0.1 * _mean_centroid_distance(v)


def test_taubin_keeps_the_volume_better_than_laplacian(mesh):
    v, f = mesh
    volume = abs(_signed_volume(v, f))
    shrink_taubin = abs(_signed_volume(taubin(v, f)[0], f) - volume)
    shrink_laplacian = abs(_signed_volume(meshlab_laplacian(v, f)[0], f) - volume)
    assert shrink_taubin < 0.25 * shrink_laplacian


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


@pytest.mark.parametrize("keep", [0.7, 0.5, 0.1])
def test_simplify_reaches_the_face_target(mesh, gim_mesh, keep):
    for v, f in (mesh, gim_mesh):
        v2, f2 = simplify(v, f, keep_fraction=keep)
        assert abs(len(f2) / len(f) - keep) <= 0.02
        assert np.array_equal(np.unique(f2), np.arange(len(v2)))
        diag = np.linalg.norm(v.max(axis=0) - v.min(axis=0))
        assert_allclose(v2.min(axis=0), v.min(axis=0), rtol=0, atol=0.05 * diag)
        assert_allclose(v2.max(axis=0), v.max(axis=0), rtol=0, atol=0.05 * diag)


@pytest.mark.parametrize("attack", [subdivide_midpoint, subdivide_loop])
def test_subdivision_splits_every_edge(mesh, gim_mesh, attack):
    for v, f in (mesh, gim_mesh):
        v2, f2 = attack(v, f)
        n_edges = len(unique_edges(f)[0])
        assert len(f2) == 4 * len(f)
        assert len(v2) == len(v) + n_edges
        assert_allclose(_areas(v2, f2).sum(), _areas(v, f).sum(), rtol=0.1)  # Loop shrinks
    assert len(attack(*mesh, iterations=2)[1]) == 16 * len(mesh[1])


def test_midpoint_subdivision_keeps_the_surface(mesh):
    v, f = mesh
    v2, f2 = subdivide_midpoint(v, f)
    assert_array_equal(v2[: len(v)], v)  # old vertices first, unmoved
    assert_allclose(_areas(v2, f2).sum(), _areas(v, f).sum(), rtol=1e-9)
    # Every new vertex is the midpoint of an edge of the input.
    edges = unique_edges(f)[0]
    mids = {tuple(np.round(m, 9)) for m in (v[edges[:, 0]] + v[edges[:, 1]]) / 2}
    assert all(tuple(np.round(p, 9)) in mids for p in v2[len(v) :])


def test_loop_subdivision_moves_the_old_vertices(mesh):
    v, f = mesh
    v2, _ = subdivide_loop(v, f)
    assert not np.allclose(v2[: len(v)], v)
    assert np.linalg.norm(v2[: len(v)] - v, axis=1).max() < 0.1 * _mean_centroid_distance(v)


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


# --- the command line ------------------------------------------------------------------------


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert err.startswith("meshwm: error: ")
    return err


@pytest.fixture(scope="module")
def gim_file(gim_mesh, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("gim") / "spot_gim64.ply"
    write_mesh(path, *gim_mesh)
    return path


SPOT = Path(__file__).parent.parent.parent / "assets" / "spot.ply"


def test_cli_attack_writes_the_attacked_mesh(tmp_path, capsys, mesh):
    out = tmp_path / "smooth.ply"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "laplacian", "--iterations", "10"]
    assert main(argv) == 0
    line = capsys.readouterr().out
    assert line.count("\n") == 1 and "laplacian(lam=0.1, iterations=10), seed 0" in line
    v, f = read_mesh(out)
    expected = laplacian(*mesh, iterations=10)
    assert_array_equal(v, expected[0])
    assert_array_equal(f, expected[1])


def test_cli_attack_json(tmp_path, capsys, mesh):
    out = tmp_path / "cropped.obj"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "crop", "--fraction", "0.3"]
    assert main([*argv, "--seed", "7", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    v, f = read_mesh(out)
    assert report["kind"] == "crop"
    assert report["params"] == {"fraction": 0.3}
    assert report["seed"] == 7
    assert (report["vertices_in"], report["faces_in"]) == (len(mesh[0]), len(mesh[1]))
    assert (report["vertices_out"], report["faces_out"]) == (len(v), len(f))
    assert report["input"] == str(SPOT) and report["output"] == str(out)
    assert_array_equal(f, crop(*mesh, seed=7, fraction=0.3)[1])


def test_cli_attack_defaults_and_option_spellings(tmp_path, capsys):
    out = tmp_path / "s.ply"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "simplify", "--json"]
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["params"] == {"keep_fraction": 0.5}
    for flag in ("--keep-fraction", "--keep_fraction"):
        assert main([*argv, "--force", flag, "0.7"]) == 0
        assert abs(json.loads(capsys.readouterr().out)["faces_out"] / 5856 - 0.7) <= 0.02


def test_cli_gim_attack_on_a_meshwm_file(tmp_path, capsys, gim_file, gim_mesh):
    out = tmp_path / "sp.ply"
    argv = ["attack", str(gim_file), "-o", str(out), "--kind", "gim_salt_pepper"]
    assert main([*argv, "--density", "0.1", "--seed", "3"]) == 0
    v, f = read_mesh(out)
    assert_array_equal(f, gim_mesh[1])
    assert_array_equal(v, gim_salt_pepper(*gim_mesh, seed=3, density=0.1)[0])
    assert "gim_salt_pepper(density=0.1), seed 3" in capsys.readouterr().out


CLI_ERRORS = [
    (["--kind", "smooth"], "invalid choice: 'smooth'"),
    (["--kind", "laplacian", "--bits", "9"], "--kind laplacian takes no --bits; its parameters: "),
    (["--kind", "reorder", "--lam", "0.5"], "its parameters: none"),
    (["--kind", "laplacian", "--foo", "1"], "unrecognized arguments: --foo 1"),
    (["--kind", "quantize", "--bits", "5"], r"quantize: bits must be an integer in 7\.\.16, got 5"),
    (["--kind", "quantize", "--bits", "x"], r"bits must be an integer in 7\.\.16, got 'x'"),
    (["--kind", "taubin", "--mu", "0.5"], r"mu must be a number in \[-1, 0\)"),
    (["--kind", "noise", "--seed", "-1"], "expected a number >= 0"),
    (["--kind", "gim_log"], "gim attacks need a mesh written by meshwm"),
    ([], "the following arguments are required: --kind"),
]


@pytest.mark.parametrize(("extra", "match"), CLI_ERRORS, ids=[" ".join(e) for e, _ in CLI_ERRORS])
def test_cli_attack_errors_exit_2_with_one_line_and_no_output(tmp_path, capsys, extra, match):
    out = tmp_path / "out.ply"
    assert main(["attack", str(SPOT), "-o", str(out), *extra]) == 2
    assert re.search(match, _one_line_error(capsys))
    assert not out.exists()


def test_cli_attack_lists_the_valid_parameters(tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(["attack", str(SPOT), "-o", str(out), "--kind", "taubin", "--bits", "9"]) == 2
    assert "its parameters: --lam, --mu, --iterations" in _one_line_error(capsys)


def test_cli_attack_missing_input(tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(["attack", str(tmp_path / "nope.ply"), "-o", str(out), "--kind", "noise"]) == 2
    assert "nope.ply" in _one_line_error(capsys)
    assert not out.exists()


def test_cli_attack_never_overwrites_its_input_without_force(tmp_path, capsys):
    src = tmp_path / "spot.ply"
    shutil.copy(SPOT, src)
    before = src.read_bytes()
    assert main(["attack", str(src), "-o", str(src), "--kind", "noise"]) == 2
    assert "--force" in _one_line_error(capsys)
    assert src.read_bytes() == before
    assert main(["attack", str(src), "-o", str(src), "--kind", "noise", "--force"]) == 0
    assert src.read_bytes() != before
    assert [p.name for p in tmp_path.iterdir()] == ["spot.ply"]  # no temporary file left


def test_cli_attack_help_lists_every_kind(capsys):
    with pytest.raises(SystemExit) as info:
        main(["attack", "--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    for name, params in ATTACK_PARAMS.items():
        assert f"  {name}: " in text
        for p in params:
            assert f"--{p.name}" in text
