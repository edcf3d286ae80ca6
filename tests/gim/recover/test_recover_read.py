"""Tests for :func:`meshwm.gim.recover.recover_grid` (:mod:`meshwm.gim.recover.read`): reading the
N×N grid back from a mesh's connectivity alone, and refusing what is no meshwm grid.

The meshes are the ones meshwm writes (:func:`meshwm.gim.to_mesh.geometry_image_to_mesh`):
an open synthetic grid, and the welded geometry images of the bundled meshes at N = 128.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from _dev_meshes import DEV, needs_dev
from _recover_grids import MESHES, SIZE, border, shuffle, synthetic_gim
from numpy.testing import assert_array_equal

from meshwm.attacks import apply_attack
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid
from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import clean_mesh

# --- the open grid (no weld) -------------------------------------------------------------------


@pytest.mark.parametrize("n", [64, 128])
def test_open_grid_reads_back_exactly_and_n_from_face_count(n):
    gim = synthetic_gim(n)
    v, f = geometry_image_to_mesh(gim)
    grid = recover_grid(v, f)
    assert grid.n == n
    assert_array_equal(grid.gim, gim)
    # Without a weld every sample is its own vertex, in row-major order.
    assert_array_equal(grid.index, np.arange(n * n).reshape(n, n))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_open_grid_ignores_vertex_and_face_order(open_grid, seed):
    gim, v, f = open_grid
    v2, f2, inverse = shuffle(v, f, seed)
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


# --- welded geometry-image meshes of the bundled models ----------------------------------------


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
    assert np.all(border(SIZE)[differs])
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
    v2, f2, inverse = shuffle(v, f, seed=7)
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


# --- meshes that are not a meshwm grid ---------------------------------------------------------


def test_random_mesh_is_refused():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    with pytest.raises(GridError, match="geometry-image grid"):
        recover_grid(np.asarray(sphere.vertices), np.asarray(sphere.faces))


def test_a_mesh_of_six_valent_vertices_is_ruled_out_before_the_search(spot_mesh):
    """The rule-out (most vertices on six triangles) answers for meshes of other origin; the
    grids every other test reads pass it, since :func:`recover_grid` asks it first."""
    from meshwm.gim.recover import rules_out_grid

    sphere = trimesh.creation.icosphere(subdivisions=3)
    assert rules_out_grid(len(sphere.vertices), np.asarray(sphere.faces))
    assert rules_out_grid(len(spot_mesh[0]), spot_mesh[1])
    with pytest.raises(GridError, match="six triangles"):
        recover_grid(np.asarray(sphere.vertices), np.asarray(sphere.faces))
    soup = np.arange(3 * len(spot_mesh[1])).reshape(-1, 3)  # as given: one face per component
    assert not rules_out_grid(len(soup.ravel()), soup)


def _split_face_disjoint_edges(v, f):
    """Split edges no two of which share a face (greedily): each new vertex lies on four
    triangles and both corners across its edge gain one, as where a mesh's longest edges
    were split."""
    mesh = trimesh.Trimesh(v, f, process=False)
    keep = np.ones(len(f), dtype=bool)
    points, added, n = [v], [], len(v)
    for (a, b), (x, y) in zip(mesh.face_adjacency, mesh.face_adjacency_edges, strict=True):
        if not (keep[a] and keep[b]):
            continue
        keep[a] = keep[b] = False
        points.append((v[x] + v[y])[None] / 2)
        for t in (f[a], f[b]):
            k = next(i for i in range(3) if {t[i], t[(i + 1) % 3]} == {x, y})
            p, q, r = t[k], t[(k + 1) % 3], t[(k + 2) % 3]
            added += [(p, n, r), (n, q, r)]
        n += 1
    return np.vstack(points), np.vstack([f[keep], np.array(added)])


def test_a_mesh_of_split_edges_is_ruled_out_though_few_vertices_lie_on_six():
    """Splitting edges puts vertices on four and on seven to nine triangles, as a 4-8 grid
    has; the faces around them still do not have a grid face's corners (two on 7-9 and one
    on 3-5, or one and two) as nearly all of a grid's do."""
    from meshwm.gim.recover import rules_out_grid
    from meshwm.gim.recover.rule_out import MAX_SIX

    sphere = trimesh.creation.icosphere(subdivisions=3)
    v, f = _split_face_disjoint_edges(np.asarray(sphere.vertices), np.asarray(sphere.faces))
    assert trimesh.Trimesh(v, f, process=False).is_watertight
    degree = np.bincount(f.ravel())
    assert np.mean(degree == 6) <= MAX_SIX / 2  # the six-valence rule alone lets it through
    assert rules_out_grid(len(v), f)
    with pytest.raises(GridError, match="4-8 grid"):
        recover_grid(v, f)


@pytest.mark.parametrize("name", MESHES)
def test_grids_are_not_ruled_out(welded, name):
    from meshwm.gim.recover import rules_out_grid

    _, v, f = welded(name)
    assert not rules_out_grid(len(v), f)


def test_input_model_is_refused(spot_mesh):
    with pytest.raises(GridError, match="geometry-image grid"):
        recover_grid(*spot_mesh)


@pytest.mark.parametrize("faces", [np.zeros((0, 3), dtype=np.int64), np.zeros((4, 2), int)])
def test_empty_or_malformed_faces_are_refused(faces):
    with pytest.raises(GridError, match="non-empty"):
        recover_grid(np.zeros((3, 3)), faces)


def test_grid_error_is_a_value_error():
    assert issubclass(GridError, ValueError)


def test_unreferenced_vertex_is_refused(welded):
    """Every vertex must be a sample: a free vertex no face uses is not part of a meshwm grid."""
    _, v, f = welded("spot_mesh")
    with pytest.raises(GridError):
        recover_grid(np.vstack([v, v.mean(axis=0)]), f)


def test_too_many_vertices_is_refused(open_grid):
    _, v, f = open_grid
    with pytest.raises(GridError, match="vertices is more than"):
        recover_grid(np.vstack([v, [[9.0, 9.0, 9.0]]]), f)


# --- meshes that only look like a grid ---------------------------------------------------------


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


# --- the development meshes --------------------------------------------------------------------


@pytest.mark.slow
@needs_dev
@pytest.mark.parametrize("path", sorted(DEV.glob("*.ply")), ids=lambda p: p.stem)
def test_every_development_mesh_reads_back_at_256(path):
    mesh = trimesh.load(path, process=False)
    g = mesh_to_geometry_image(np.asarray(mesh.vertices), np.asarray(mesh.faces), size=256)
    v, f = geometry_image_to_mesh(g.gim, g.weld)
    grid = recover_grid(v, f)
    assert grid.n == 256 and grid.coverage == 1.0
    differs = np.any(grid.gim != g.gim, axis=-1)
    assert np.all(border(256)[differs])  # fold tips only
    assert_array_equal(np.unique(grid.index), np.arange(len(v)))
