"""Tests for :mod:`meshwm.gim.recover`: reading the N×N grid back from a mesh's connectivity alone.

The meshes are the ones meshwm writes (:func:`meshwm.gim.to_mesh.geometry_image_to_mesh`):
an open synthetic grid, and the welded geometry images of the bundled meshes at N = 128; whole,
or cropped (:func:`meshwm.attacks.library.crop`), or cut into pieces.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_array_equal

import meshwm.gim.recover as grid_module
from meshwm.attacks.library import apply_attack, crop
from meshwm.errors import GridError
from meshwm.gim.code import code_cells, flipped_cells
from meshwm.gim.recover import drop_irregular, recover_grid
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import clean_mesh

SIZE = 128
MESHES = ["spot_mesh", "kitten_mesh", "plane_mesh"]


def _synthetic_gim(n: int) -> np.ndarray:
    """A bumpy sheet whose samples are all distinct."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return np.stack([i / n, j / n, 0.1 * np.sin(i / 5.0) * np.cos(j / 7.0)], axis=-1)


def _border(n: int) -> np.ndarray:
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return (i == 0) | (j == 0) | (i == n - 1) | (j == n - 1)


@pytest.fixture(scope="module")
def welded(request):
    """(GeometryImage, vertices, faces) of each bundled mesh at N = 128, built once."""
    cache = {}

    def get(name):
        if name not in cache:
            g = mesh_to_geometry_image(*request.getfixturevalue(name), size=SIZE)
            cache[name] = (g, *geometry_image_to_mesh(g.gim, g.weld))
        return cache[name]

    return get


@pytest.fixture(scope="module")
def open_grid():
    gim = _synthetic_gim(64)
    v, f = geometry_image_to_mesh(gim)
    return gim, v, f


def _shuffle(v, f, seed):
    """Random vertex order, face order and cyclic rotation of each face's corners."""
    rng = np.random.default_rng(seed)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    f2 = inverse[f][rng.permutation(len(f))]
    shift = rng.integers(0, 3, size=len(f2))
    f2 = np.take_along_axis(f2, (np.arange(3) + shift[:, None]) % 3, axis=1)
    return v[perm], f2, inverse


# --- the open grid (no weld) --------------------------------------------------------------


@pytest.mark.parametrize("n", [64, 128])
def test_open_grid_reads_back_exactly_and_n_from_face_count(n):
    gim = _synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    grid = recover_grid(v, f)
    assert grid.n == n
    assert_array_equal(grid.gim, gim)
    # Without a weld every sample is its own vertex, in row-major order.
    assert_array_equal(grid.index, np.arange(n * n).reshape(n, n))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_open_grid_ignores_vertex_and_face_order(open_grid, seed):
    gim, v, f = open_grid
    v2, f2, inverse = _shuffle(v, f, seed)
    grid = recover_grid(v2, f2)
    assert_array_equal(grid.gim, gim)
    assert_array_equal(grid.index, inverse.reshape(64, 64))


def test_open_grid_with_reversed_winding(open_grid):
    gim, v, f = open_grid
    grid = recover_grid(v, f[:, ::-1])
    assert_array_equal(grid.gim, gim)


def test_open_grid_ignores_geometry(open_grid):
    """Only connectivity is read: collapsing every vertex onto one point changes nothing."""
    _, v, f = open_grid
    grid = recover_grid(np.zeros_like(v), f)
    assert_array_equal(grid.index, np.arange(64 * 64).reshape(64, 64))


# --- welded geometry-image meshes of the bundled models -----------------------------------


def _samples_that_are_vertices(weld: np.ndarray) -> np.ndarray:
    """(N, N) bool: the samples whose weld root is a vertex of the written mesh.

    Written from an image whose x holds each sample's own index, every output vertex carries
    the index of the root sample it came from.
    """
    n = len(weld)
    ids = np.zeros((n, n, 3))
    ids[..., 0] = np.arange(n * n).reshape(n, n)
    v, f = geometry_image_to_mesh(ids, weld)
    roots = v[np.unique(f), 0].astype(np.int64)
    return np.isin(weld, roots)


@pytest.mark.parametrize("name", MESHES)
def test_welded_mesh_reads_back_the_geometry_image(welded, name):
    """The recovered image is the written one, except at fold tips: border samples that are
    no vertex of the mesh (their triangles closed into dropped fins)."""
    g, v, f = welded(name)
    grid = recover_grid(v, f)
    assert grid.n == SIZE
    differs = np.any(grid.gim != g.gim, axis=-1)
    assert np.all(_border(SIZE)[differs])
    is_vertex = _samples_that_are_vertices(g.weld)
    assert not np.any(is_vertex[differs])
    # Fold tips are few (recover_grid gives up beyond 4N).
    assert differs.sum() <= 4 * SIZE


@pytest.mark.parametrize("name", MESHES)
def test_index_maps_onto_the_vertices(welded, name):
    _, v, f = welded(name)
    grid = recover_grid(v, f)
    assert grid.index.shape == (SIZE, SIZE)
    assert grid.index.min() >= 0 and grid.index.max() < len(v)
    assert_array_equal(np.unique(grid.index), np.arange(len(v)))  # every vertex is a sample
    assert_array_equal(grid.gim, v[grid.index])


@pytest.mark.parametrize("name", MESHES)
def test_welded_recovery_ignores_order(welded, name):
    _, v, f = welded(name)
    grid = recover_grid(v, f)
    v2, f2, inverse = _shuffle(v, f, seed=7)
    moved = recover_grid(v2, f2)
    assert_array_equal(moved.gim, grid.gim)
    assert_array_equal(moved.index, inverse[grid.index])


@pytest.mark.parametrize("name", MESHES)
def test_welded_recovery_ignores_reversed_winding(welded, name):
    _, v, f = welded(name)
    grid = recover_grid(v, f)
    flipped = recover_grid(v, f[:, ::-1])
    # Same samples, not a transposed or mirrored reading.
    assert_array_equal(flipped.index, grid.index)


@pytest.mark.parametrize("name", MESHES)
def test_welded_recovery_survives_an_stl_round_trip(welded, name):
    """STL stores float32 triangle soup; after re-welding by position the grid reads the same
    samples, rounded to single precision."""
    _, v, f = welded(name)
    grid = recover_grid(v, f)
    clean = clean_mesh(*apply_attack("round_trip", v, f, suffix=".stl"))
    back = recover_grid(clean.vertices, clean.faces)
    assert back.n == SIZE
    assert_array_equal(back.gim, grid.gim.astype(np.float32).astype(np.float64))


# --- meshes that are not a meshwm grid ----------------------------------------------------


def test_random_mesh_is_refused():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    with pytest.raises(GridError, match="no 32 x 32 geometry-image grid"):
        recover_grid(np.asarray(sphere.vertices), np.asarray(sphere.faces))


def test_input_model_is_refused(spot_mesh):
    with pytest.raises(GridError, match="geometry-image grid"):
        recover_grid(*spot_mesh)


@pytest.mark.parametrize("faces", [np.zeros((0, 3), dtype=np.int64), np.zeros((4, 2), int)])
def test_empty_or_malformed_faces_are_refused(faces):
    with pytest.raises(GridError, match="non-empty"):
        recover_grid(np.zeros((3, 3)), faces)


def test_grid_error_is_a_value_error():
    assert issubclass(GridError, ValueError)


def _cell_faces(n: int, i: int, j: int) -> slice:
    cell = i * (n - 1) + j
    return slice(2 * cell, 2 * cell + 2)


def _plain_cell(n: int, i: int, j: int) -> np.ndarray:
    """The two triangles of cell (i, j) with the 4-8 diagonal (as if not a flipped code cell)."""
    p00 = i * n + j
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    if (i + j) % 2 == 0:
        return np.array([[p00, p01, p11], [p00, p11, p10]])
    return np.array([[p00, p01, p10], [p01, p11, p10]])


def _unflip(f: np.ndarray, n: int, cells) -> np.ndarray:
    f = f.copy()
    for i, j in cells:
        f[_cell_faces(n, i, j)] = _plain_cell(n, i, j)
    return f


def test_without_the_position_code_no_grid_is_found(open_grid):
    """A plain 4-8 grid has no flipped code cell: nothing to seed from, nothing to orient by."""
    _, v, f = open_grid
    with pytest.raises(GridError, match="0 hypotheses"):
        recover_grid(v, _unflip(f, 64, flipped_cells(64)))


@pytest.mark.parametrize("k", [0, 100, 300])
def test_one_code_cell_flipped_back_is_refused(open_grid, k):
    """A wrong diagonal is a contradiction the walk meets: refused, never read around."""
    _, v, f = open_grid
    with pytest.raises(GridError, match="no 64 x 64 geometry-image grid"):
        recover_grid(v, _unflip(f, 64, flipped_cells(64)[k : k + 1]))


@pytest.mark.parametrize("cell", [(10, 10), (40, 20)])
def test_face_removed_from_the_interior_still_reads(open_grid, cell):
    """A missing face is tolerated when the walk still reaches every sample around it."""
    gim, v, f = open_grid
    grid = recover_grid(v, np.delete(f, _cell_faces(64, *cell).start, axis=0))
    assert_array_equal(grid.gim, gim)


def test_unreferenced_vertex_is_refused(welded):
    """Every vertex must be a sample: a free vertex no face uses is not part of a meshwm grid."""
    _, v, f = welded("spot_mesh")
    with pytest.raises(GridError):
        recover_grid(np.vstack([v, v.mean(axis=0)]), f)


def test_too_many_vertices_is_refused(open_grid):
    _, v, f = open_grid
    with pytest.raises(GridError, match="vertices is more than"):
        recover_grid(np.vstack([v, [[9.0, 9.0, 9.0]]]), f)


# --- the position code ----------------------------------------------------------------------


@pytest.mark.parametrize("n", [16, 64, 256, 2048])
def test_code_cells_share_no_sample_and_keep_off_the_border(n):
    cells = code_cells(n)
    assert len(cells) == (n // 2 - 2) ** 2
    assert np.all(cells % 2 == 0)
    assert cells.min() >= 2 and cells.max() <= n - 4  # corners 2 .. N-3: off the border ring
    flipped = flipped_cells(n)
    assert 0.3 < len(flipped) / len(cells) < 0.7
    assert np.all(np.isin(flipped[:, 0] * n + flipped[:, 1], cells[:, 0] * n + cells[:, 1]))


def test_code_is_sha256_of_a_public_tag():
    """SHA-256 in counter mode, no random stream: the same bits on every machine, and each N
    has its own code."""
    n = 64
    stream = b"".join(
        hashlib.sha256(b"meshwm/grid/v2/64/" + k.to_bytes(8, "big")).digest() for k in range(4)
    )
    bits = np.unpackbits(np.frombuffer(stream, dtype=np.uint8))[: len(code_cells(n))]
    assert_array_equal(flipped_cells(n), code_cells(n)[bits.astype(bool)])
    cells = code_cells(64)
    key = cells[:, 0] * 1000 + cells[:, 1]
    in_small = np.isin(key, flipped_cells(64)[:, 0] * 1000 + flipped_cells(64)[:, 1])
    in_large = np.isin(key, flipped_cells(128)[:, 0] * 1000 + flipped_cells(128)[:, 1])
    assert not np.array_equal(in_small, in_large)


@pytest.mark.parametrize("n", [16, 32, 64, 128, 256, 512, 1024, 2048])
def test_code_has_no_symmetry_of_the_square(n):
    """No symmetry of the square (other than the identity) maps the flipped cells onto
    themselves, so neither a turned nor a mirrored reading (reversed winding) can verify."""
    flipped = flipped_cells(n)
    key = np.sort(flipped[:, 0] * n + flipped[:, 1])
    i, j = flipped[:, 0], flipped[:, 1]
    m = n - 2  # cell (i, j) -> (m - i, j) etc.: cells map to cells
    images = [
        (j, m - i),
        (m - i, m - j),
        (m - j, i),
        (j, i),
        (m - i, j),
        (m - j, m - i),
        (i, m - j),
    ]
    for a, b in images:
        assert not np.array_equal(np.sort(a * n + b), key)


# --- cropped meshes -------------------------------------------------------------------------


def _source_of(full_v: np.ndarray, part_v: np.ndarray) -> np.ndarray:
    """Index in ``full_v`` of each vertex of ``part_v`` (a crop keeps positions exactly)."""
    where = {tuple(p): k for k, p in enumerate(full_v.tolist())}
    assert len(where) == len(full_v)  # positions identify vertices
    return np.array([where[tuple(p)] for p in part_v.tolist()], dtype=np.int64)


def _expected(full_index: np.ndarray, full_v, part_v) -> np.ndarray:
    """(N, N) vertex of ``part_v`` that each sample must read as, -1 where it is gone."""
    remap = np.full(len(full_v), -1, dtype=np.int64)
    remap[_source_of(full_v, part_v)] = np.arange(len(part_v))
    return remap[full_index]


def _check_partial(grid, expected: np.ndarray, n_vertices: int) -> float:
    """No false sample; returns the fraction of the piece's vertices that were read."""
    assert grid.index.shape == expected.shape
    found = grid.index >= 0
    assert_array_equal(grid.index[found], expected[found])  # nothing false
    assert np.all(np.isnan(grid.gim[~found]))
    assert grid.coverage == pytest.approx(found.mean())
    return len(np.unique(grid.index[found])) / n_vertices


def _away_from_cuts(n_vertices: int, f: np.ndarray, min_faces: int = 400) -> np.ndarray:
    """Vertices with a closed fan (no face of theirs was removed, none on the grid's own open
    border) in a component of at least ``min_faces`` faces (enough to hold the code)."""
    directed = {
        (int(a), int(b)) for a, b in np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    }
    closed = np.ones(n_vertices, dtype=bool)
    for a, b in directed:
        if (b, a) not in directed:
            closed[a] = closed[b] = False
    mesh = trimesh.Trimesh(np.zeros((n_vertices, 3)), f, process=False)
    big = np.zeros(n_vertices, dtype=bool)
    for part in trimesh.graph.connected_components(mesh.face_adjacency, nodes=np.arange(len(f))):
        if len(part) >= min_faces:
            big[np.unique(f[part])] = True
    return closed & big


def _check_cut(grid, expected: np.ndarray, v: np.ndarray, f: np.ndarray) -> None:
    """No false sample, and every vertex away from the cuts is read (at a cut, border samples
    whose neighbours lost faces may stay unread: a fold could not be ruled out there)."""
    _check_partial(grid, expected, len(v))
    read = np.zeros(len(v), dtype=bool)
    read[grid.index[grid.index >= 0]] = True
    away = _away_from_cuts(len(v), f)
    assert away.sum() > 0.5 * len(v)
    assert np.all(read[away])


@pytest.fixture(scope="module")
def sheet():
    """The open synthetic grid at N = 64 with its index (row-major: sample k is vertex k)."""
    gim = _synthetic_gim(64)
    v, f = geometry_image_to_mesh(gim)
    return v, f, np.arange(64 * 64).reshape(64, 64)


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cropped_sheet_reads_every_surviving_vertex(sheet, fraction, seed):
    v, f, index = sheet
    cv, cf = crop(v, f, seed=seed, fraction=fraction)
    cv2, cf2, inverse = _shuffle(cv, cf, seed)
    grid = recover_grid(cv2, cf2)
    assert grid.n == 64
    expected = _expected(index, v, cv)
    expected = np.where(expected >= 0, inverse[np.maximum(expected, 0)], -1)
    _check_cut(grid, expected, cv2, cf2)
    assert _check_partial(grid, expected, len(cv)) > 0.95
    assert grid.coverage < 1.0 and grid.hypotheses >= 8


def test_crop_with_the_centre_removed(sheet):
    """A hole where the old centre fiducial was: the code is everywhere else."""
    v, f, index = sheet
    centre = v[f].mean(axis=1)[:, :2] - v[:, :2].mean(axis=0)
    keep = np.linalg.norm(centre, axis=1) > 0.2
    cv, cf = _compact(v, f[keep])
    grid = recover_grid(cv, cf)
    _check_cut(grid, _expected(index, v, cv), cv, cf)
    assert grid.index[32, 32] == -1


def _compact(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    return v[used], (np.cumsum(used) - 1)[f]


def test_pieces_are_read_and_merged(sheet):
    """Two bands removed: three components, each seeded and read on its own, then merged."""
    v, f, index = sheet
    x = v[f].mean(axis=1)[:, 1]
    keep = ~(((x > 0.3) & (x < 0.35)) | ((x > 0.65) & (x < 0.7)))
    cv, cf = _compact(v, f[keep])
    grid = recover_grid(cv, cf)
    assert grid.components == 3
    _check_cut(grid, _expected(index, v, cv), cv, cf)


def test_small_piece_is_ignored(sheet):
    """A piece too small to hold a few dozen code bits is left out (its samples read -1)."""
    v, f, index = sheet
    x = v[f].mean(axis=1)[:, 1]
    keep = (x < 0.6) | (x > 0.65)
    keep &= ~((x > 0.65) & (v[f].mean(axis=1)[:, 0] > 0.1))  # a strip 3 samples wide is left
    cv, cf = _compact(v, f[keep])
    grid = recover_grid(cv, cf)
    assert grid.components == 1
    expected = _expected(index, v, cv)
    found = grid.index >= 0
    assert_array_equal(grid.index[found], expected[found])
    assert np.all(grid.index[:, 42:] == -1)


def test_cropped_sheet_with_reversed_winding(sheet):
    v, f, index = sheet
    cv, cf = crop(v, f, seed=4, fraction=0.3)
    grid = recover_grid(cv, cf[:, ::-1])
    _check_cut(grid, _expected(index, v, cv), cv, cf)
    assert_array_equal(grid.index, recover_grid(cv, cf).index)


def test_cropped_mesh_gives_n_by_the_code_not_the_face_count(sheet):
    """A fifth of the faces fit a 32-grid; 32 is tried first and the code says 64."""
    v, f, index = sheet
    cv, cf = crop(v, f, seed=1, fraction=0.8)
    assert 2 * 31**2 >= len(cf)
    grid = recover_grid(cv, cf)
    assert grid.n == 64
    assert grid.hypotheses % 3 == 0  # sizes 32, 64 and 128 tried
    _check_cut(grid, _expected(index, v, cv), cv, cf)
    sized = recover_grid(cv, cf, size=64)
    assert_array_equal(sized.index, grid.index)
    assert sized.hypotheses < grid.hypotheses
    with pytest.raises(GridError):
        recover_grid(cv, cf, size=32)


def test_partial_result_does_not_depend_on_the_order(sheet):
    v, f, _ = sheet
    cv, cf = crop(v, f, seed=5, fraction=0.4)
    grid = recover_grid(cv, cf)
    for seed in (1, 2):
        v2, f2, inverse = _shuffle(cv, cf, seed)
        moved = recover_grid(v2, f2)
        assert_array_equal(moved.index, np.where(grid.index >= 0, inverse[grid.index], -1))
        assert moved.hypotheses == grid.hypotheses
        assert moved.coverage == grid.coverage


@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cropped_welded_mesh_has_no_false_sample(welded, fraction, seed):
    """Spot at N = 128: a crop can leave pieces connected only across a welded seam, which
    are seeded again; every sample read is right, and nearly every vertex is read."""
    _, v, f = welded("spot_mesh")
    full = recover_grid(v, f)
    cv, cf = crop(v, f, seed=seed, fraction=fraction)
    grid = recover_grid(cv, cf)
    assert grid.n == SIZE
    # Fold tips were filled from a neighbour in the complete reading: they are no sample here.
    expected = _expected(full.index, v, cv)
    read = _check_partial(grid, expected, len(cv))
    assert read >= 0.97


def test_size_is_checked(sheet):
    v, f, _ = sheet
    with pytest.raises(ValueError, match="power of two"):
        recover_grid(v, f, size=100)


# --- meshes that only look like a grid ------------------------------------------------------


def test_random_diagonals_are_refused(sheet):
    v, _, _ = sheet
    n = 64
    rng = np.random.default_rng(3)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    p00 = (i * n + j).ravel()
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    main = (rng.random(len(p00)) < 0.5)[:, None]
    t1 = np.where(main, np.stack([p00, p01, p11], 1), np.stack([p00, p01, p10], 1))
    t2 = np.where(main, np.stack([p00, p11, p10], 1), np.stack([p01, p11, p10], 1))
    with pytest.raises(GridError, match="geometry-image grid"):
        recover_grid(v, np.stack([t1, t2], 1).reshape(-1, 3))


def test_triangulated_point_cloud_is_refused():
    """A Delaunay triangulation of random points in the square: no grid at all."""
    from scipy.spatial import Delaunay

    pts = np.random.default_rng(0).random((3000, 2))
    tri = Delaunay(pts).simplices
    with pytest.raises(GridError, match="geometry-image grid"):
        recover_grid(np.c_[pts, np.zeros(len(pts))], tri)


# --- the development meshes -----------------------------------------------------------------

DEV = Path(__file__).resolve().parent.parent.parent.parent / "shared" / "meshes"


@pytest.mark.slow
@pytest.mark.skipif(not DEV.is_dir(), reason="../shared/meshes is not there")
@pytest.mark.parametrize("path", sorted(DEV.glob("*.ply")), ids=lambda p: p.stem)
def test_every_development_mesh_reads_back_at_256(path):
    mesh = trimesh.load(path, process=False)
    g = mesh_to_geometry_image(np.asarray(mesh.vertices), np.asarray(mesh.faces), size=256)
    v, f = geometry_image_to_mesh(g.gim, g.weld)
    grid = recover_grid(v, f)
    assert grid.n == 256 and grid.coverage == 1.0
    differs = np.any(grid.gim != g.gim, axis=-1)
    assert np.all(_border(256)[differs])  # fold tips only
    assert_array_equal(np.unique(grid.index), np.arange(len(v)))


def test_other_components_with_many_faces_do_not_hide_the_size():
    """meshwm passes other components through; their faces must not push N up a size."""
    n = 32
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    gim = np.stack([i, j, np.sin(i + j)], axis=-1).astype(float)
    v, f = geometry_image_to_mesh(gim)
    extra_v, extra_f = geometry_image_to_mesh(gim[:24, :24] + [100.0, 0.0, 0.0])
    both_v = np.concatenate([v, extra_v])
    both_f = np.concatenate([f, extra_f + len(v)])
    assert len(both_f) > 2 * (n - 1) ** 2  # the face count alone would say N = 64
    grid = recover_grid(both_v, both_f)
    assert grid.n == n and grid.coverage == 1.0
    assert np.array_equal(grid.gim, gim)


def _weld(v: np.ndarray, f: np.ndarray, pairs: list[tuple[int, int]]):
    """Merge vertex b into a for each pair, as a welding filter does: drop collapsed faces."""
    target = np.arange(len(v))
    for a, b in pairs:
        target[b] = a
    f = target[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return v[used], remap[f], np.flatnonzero(used)


@pytest.mark.parametrize(
    "offsets",
    [
        [(0, 1)],  # grid neighbours
        [(1, 1)],  # across a diagonal
        [(0, 2)],  # two apart: a fold of the surface
        [(0, 1), (1, 1), (0, 2), (2, 0)],  # several at once, far apart
    ],
)
def test_welded_samples_read_as_holes(open_grid, offsets):
    """Interior samples merged into one vertex break the walk; without the faces around the
    irregular vertices the rest reads exactly and only samples near the merges are missing."""
    n = 64
    _, v, f = open_grid
    where = [(20, 20), (40, 30), (25, 45), (45, 12)][: len(offsets)]
    pairs = [
        (i * n + j, (i + di) * n + j + dj) for (i, j), (di, dj) in zip(where, offsets, strict=True)
    ]
    wv, wf, kept = _weld(v, f, pairs)
    rv, rf, kept2 = drop_irregular(wv, wf)
    assert len(rv) >= 0.99 * len(wv)
    grid = recover_grid(rv, rf)
    truth = kept[kept2]  # original sample of each vertex left
    found = grid.index >= 0
    assert_array_equal(truth[grid.index[found]], np.flatnonzero(found.ravel()))
    missing = np.argwhere(~found)
    assert len(missing) <= 16 * len(pairs)
    near = np.array(where)
    assert np.all(np.abs(missing[:, None, :] - near[None]).max(axis=2).min(axis=1) <= 3)


def test_drop_irregular_keeps_a_clean_grid_interior(open_grid):
    _, v, f = open_grid
    rv, rf, _ = drop_irregular(v, f)
    # An open grid's irregular vertices are its four corners' neighbourhoods at most.
    assert len(rv) >= len(v) - 16
    assert recover_grid(rv, rf).n == 64


# --- the fast path: faces in the order meshwm wrote them ----------------------------------


def _order_free(monkeypatch, v, f, **kwargs):
    """recover_grid without the face-order fast path."""
    with monkeypatch.context() as m:
        m.setattr(grid_module, "_read_in_order", lambda *a: None)
        return recover_grid(v, f, **kwargs)


def _spy(monkeypatch) -> list[bool]:
    """Record whether each fast-path attempt succeeded."""
    calls: list[bool] = []
    real = grid_module._read_in_order

    def spy(*args):
        got = real(*args)
        calls.append(got is not None)
        return got

    monkeypatch.setattr(grid_module, "_read_in_order", spy)
    return calls


def _assert_same_reading(a, b) -> None:
    assert (a.n, a.hypotheses, a.coverage, a.components) == (
        b.n,
        b.hypotheses,
        b.coverage,
        b.components,
    )
    assert_array_equal(a.index, b.index)
    assert_array_equal(a.gim, b.gim)


@pytest.mark.parametrize("name", MESHES)
def test_fast_path_reads_what_the_order_free_reader_reads(welded, name, monkeypatch):
    """Welded seams, collapsed border triangles, fold tips: the same reading, taken fast."""
    _, v, f = welded(name)
    slow = _order_free(monkeypatch, v, f)
    calls = _spy(monkeypatch)
    fast = recover_grid(v, f)
    assert calls and calls[-1]  # the fast path read it
    _assert_same_reading(fast, slow)


def test_fast_path_on_the_open_grid_and_with_size(open_grid, monkeypatch):
    gim, v, f = open_grid
    slow = _order_free(monkeypatch, v, f, size=64)
    calls = _spy(monkeypatch)
    for kwargs in ({}, {"size": 64}):
        fast = recover_grid(v, f, **kwargs)
        assert calls[-1]
        _assert_same_reading(fast, slow if kwargs else _order_free(monkeypatch, v, f))
    assert_array_equal(fast.gim, gim)


def test_fast_path_with_other_components_counts_their_hypotheses(monkeypatch):
    """Passed-through components after the grid: read (and counted) as the order-free
    reader reads them; one that holds a grid of its own is left to that reader."""
    n = 32
    gim = _synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    extra_v, extra_f = geometry_image_to_mesh(_synthetic_gim(24) + np.array([5.0, 0.0, 0.0]))
    both_v = np.concatenate([v, extra_v])
    both_f = np.concatenate([f, extra_f + len(v)])
    slow = _order_free(monkeypatch, both_v, both_f)
    calls = _spy(monkeypatch)
    fast = recover_grid(both_v, both_f)
    _assert_same_reading(fast, slow)
    assert any(calls)
    assert fast.hypotheses > recover_grid(v, f).hypotheses  # the extra piece's seeds count
    # A second grid after the first: the order-free reader decides.
    second_v, second_f = geometry_image_to_mesh(_synthetic_gim(n) + np.array([5.0, 0.0, 0.0]))
    two_v = np.concatenate([v, second_v])
    two_f = np.concatenate([f, second_f + len(v)])
    calls.clear()
    got = recover_grid(two_v, two_f)
    assert not any(calls)
    _assert_same_reading(got, _order_free(monkeypatch, two_v, two_f))


@pytest.mark.parametrize("name", MESHES)
def test_fast_path_declines_what_it_cannot_verify(welded, name, monkeypatch):
    """Faces out of order, corners rotated, winding reversed, an interior face gone or two
    swapped: no fast reading, and the order-free reader's result stands."""
    _, v, f = welded(name)
    n = SIZE
    rotated = f.copy()
    rotated[5000] = rotated[5000, [1, 2, 0]]
    swapped = f.copy()
    swapped[[4000, 4001]] = swapped[[4001, 4000]]
    w = 2 * (n - 1)
    interior = 60 * w + 2 * 60  # first face of cell (60, 60)
    cases = {
        "reversed": f[::-1],
        "winding": f[:, ::-1],
        "rotated": rotated,
        "swapped": swapped,
        "missing": np.delete(f, interior, axis=0),
    }
    for label, faces in cases.items():
        calls = _spy(monkeypatch)
        try:
            got = recover_grid(v, faces)
        except GridError:
            got = None
        assert not any(calls), label
        monkeypatch.undo()
        try:
            want = _order_free(monkeypatch, v, faces)
        except GridError:
            want = None
        if want is None:
            assert got is None, label
        else:
            _assert_same_reading(got, want)


def test_many_faces_in_other_components_still_read(monkeypatch):
    """More faces in all than the largest grid has (here: with the largest grid made 64):
    the size comes from the largest component, fast path or not."""
    monkeypatch.setattr(grid_module, "_MAX_SIZE", 64)
    n = 32
    gim = _synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    k = 2 * 63**2 + 1 - len(f)  # loose triangles, so that the total exceeds 2 * 63^2
    rng = np.random.default_rng(3)
    soup_v = rng.normal(size=(3 * k, 3)) + 10.0
    soup_f = np.arange(3 * k).reshape(k, 3) + len(v)
    both_v, both_f = np.concatenate([v, soup_v]), np.concatenate([f, soup_f])
    assert len(both_f) > 2 * 63**2
    grid = recover_grid(both_v, both_f)
    assert grid.n == n and grid.coverage == 1.0
    assert_array_equal(grid.gim, gim)
    _assert_same_reading(grid, _order_free(monkeypatch, both_v, both_f))
