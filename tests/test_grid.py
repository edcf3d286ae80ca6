"""Tests for :mod:`meshwm.grid`: reading the N×N grid back from a mesh's connectivity alone.

The meshes are the ones meshwm writes (:func:`meshwm.geometry_image.geometry_image_to_mesh`):
an open synthetic grid, and the welded geometry images of the bundled meshes at N = 128.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_array_equal

from meshwm.attacks import apply_attack
from meshwm.clean import clean_mesh
from meshwm.geometry_image import (
    fiducial_cells,
    geometry_image_to_mesh,
    mesh_to_geometry_image,
)
from meshwm.grid import GridError, recover_grid

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
    """The two triangles of cell (i, j) with the regular (non-fiducial) diagonal."""
    p00 = i * n + j
    p01, p10, p11 = p00 + 1, p00 + n, p00 + n + 1
    if (i + j) % 2 == 0:
        return np.array([[p00, p01, p11], [p00, p11, p10]])
    return np.array([[p00, p01, p10], [p01, p11, p10]])


@pytest.mark.parametrize("cells", [[0], [1], [2], [0, 1, 2]])
def test_fiducial_flipped_back_is_refused(open_grid, cells):
    _, v, f = open_grid
    f = f.copy()
    n = 64
    for k in cells:
        i, j = fiducial_cells(n)[k]
        f[_cell_faces(n, i, j)] = _plain_cell(n, i, j)
    with pytest.raises(GridError, match="0 fiducial candidates"):
        recover_grid(v, f)


def test_face_removed_at_the_fiducial_is_refused(open_grid):
    _, v, f = open_grid
    i, j = fiducial_cells(64)[0]
    with pytest.raises(GridError):
        recover_grid(v, np.delete(f, _cell_faces(64, i, j).start, axis=0))


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
