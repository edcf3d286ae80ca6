"""Tests for :mod:`meshwm.gim.remesh`: remeshing onto an N×N grid and back."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from meshwm.errors import MeshError
from meshwm.gim.remesh import (
    code_cells,
    flipped_cells,
    geometry_image_to_mesh,
    grid_faces,
    mesh_to_geometry_image,
)
from meshwm.mesh.clean import edge_topology_counts
from meshwm.metrics import bounding_box_diagonal, surface_distance


def _ellipsoid(subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(sphere.vertices) * [2.0, 1.0, 0.5], np.asarray(sphere.faces, np.int64)


def _loops(faces: np.ndarray) -> int:
    mesh = trimesh.Trimesh(np.zeros((faces.max() + 1, 3)), faces, process=False)
    return len(
        trimesh.graph.connected_components(
            mesh.edges[trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)]
        )
    )


@pytest.fixture(scope="module")
def spot_gim(spot_mesh):
    return mesh_to_geometry_image(*spot_mesh, size=128)


def test_grid_faces_cover_every_cell_counter_clockwise():
    n = 6
    f = grid_faces(n)
    assert f.shape == (2 * (n - 1) ** 2, 3)
    uv = np.stack(np.meshgrid(np.arange(n), np.arange(n)), axis=-1).reshape(-1, 2)
    a, b, c = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert np.all(cross == 1)  # every triangle is half a unit cell, counter-clockwise


def test_grid_diagonals_alternate_so_connectivity_shows_the_grid():
    """Interior samples with i + j even have 8 neighbours, the others 4 (a 4-8 mesh), except at
    the flipped code cells, whose corners have 7 and 5; diagonals join two i + j even samples
    except in a flipped code cell, where they join its two odd corners."""
    n = 32
    f = grid_faces(n)
    edges = np.unique(
        np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0
    )
    valence = np.bincount(edges.ravel(), minlength=n * n).reshape(n, n)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    flipped = flipped_cells(n)
    near = np.zeros((n, n), dtype=bool)
    for a in (0, 1):
        for b in (0, 1):
            near[flipped[:, 0] + a, flipped[:, 1] + b] = True
    inner = (i > 0) & (i < n - 1) & (j > 0) & (j < n - 1)
    even = (i + j) % 2 == 0
    assert np.all(valence[inner & ~near & even] == 8)
    assert np.all(valence[inner & ~near & ~even] == 4)
    assert np.all(valence[near & even] == 7)
    assert np.all(valence[near & ~even] == 5)
    parity = ((i + j) % 2).ravel()
    rows, cols = edges // n, edges % n
    diagonal = (np.abs(rows[:, 0] - rows[:, 1]) == 1) & (np.abs(cols[:, 0] - cols[:, 1]) == 1)
    even_pair = (parity[edges[:, 0]] == 0) & (parity[edges[:, 1]] == 0)
    cell = rows.min(axis=1) * n + cols.min(axis=1)
    in_code = np.isin(cell, flipped[:, 0] * n + flipped[:, 1]) & diagonal
    assert np.array_equal(diagonal & ~in_code, even_pair & ~in_code)
    assert not np.any(even_pair[in_code])  # a flipped cell's diagonal joins its odd corners


def test_code_cells_keep_off_the_border_and_share_no_sample():
    n = 64
    cells = code_cells(n)
    shifts = np.array([[0, 0], [0, 1], [1, 0], [1, 1]])
    corners = (cells[None, :, :] + shifts[:, None, :]).reshape(-1, 2)
    assert len(np.unique(corners[:, 0] * n + corners[:, 1])) == 4 * len(cells)
    assert corners.min() >= 2 and corners.max() <= n - 3


def test_shape_dtype_and_no_nan(spot_gim):
    assert spot_gim.gim.shape == (128, 128, 3)
    assert spot_gim.gim.dtype == np.float64
    assert np.isfinite(spot_gim.gim).all()
    assert spot_gim.report["flipped_triangles"] == 0


def test_welded_samples_are_bit_identical(spot_gim):
    flat = spot_gim.gim.reshape(-1, 3)
    root = spot_gim.weld.ravel()
    assert np.array_equal(flat, flat[root])
    assert np.array_equal(root[root], root)  # idempotent: every root is its own root
    assert spot_gim.report["welded_samples"] > 0


def test_single_cut_seams_follow_the_paper_layout():
    """One cut path A -> B: (i, 0) = (0, i) and (N-1, j) = (j, N-1), exactly (issue #2)."""
    v, f = _ellipsoid()
    g = mesh_to_geometry_image(v, f, size=64)
    assert g.report["cut_paths"] == 1
    gim = g.gim
    assert np.array_equal(gim[:, 0], gim[0, :])
    assert np.array_equal(gim[-1, :], gim[:, -1])
    assert np.array_equal(gim[-1, 0], gim[0, -1])


@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh"])
def test_closed_input_gives_closed_output_of_the_same_genus(fixture, request):
    v, f = request.getfixturevalue(fixture)
    g = mesh_to_geometry_image(v, f, size=128)
    out_v, out_f = geometry_image_to_mesh(g.gim, g.weld)
    mesh = trimesh.Trimesh(out_v, out_f, process=False)
    assert mesh.is_watertight
    assert mesh.is_winding_consistent
    chi_out = len(out_v) - edge_topology_counts(out_f)[0] + len(out_f)
    assert chi_out == g.report["euler_characteristic"]


def test_orientation_follows_the_input(spot_mesh):
    v, f = spot_mesh
    g = mesh_to_geometry_image(v, f, size=128)
    out = trimesh.Trimesh(*geometry_image_to_mesh(g.gim, g.weld), process=False)
    flipped = trimesh.Trimesh(*geometry_image_to_mesh(*_reflect(v, f)), process=False)
    assert out.volume > 0
    assert flipped.volume > 0  # a mirrored input is still oriented outward


def _reflect(v, f):
    g = mesh_to_geometry_image(v * [-1.0, 1.0, 1.0], f[:, ::-1], size=64)
    return g.gim, g.weld


def test_open_mesh_keeps_its_holes(plane_mesh):
    v, f = plane_mesh
    g = mesh_to_geometry_image(v, f, size=256)
    _, out_f = geometry_image_to_mesh(g.gim, g.weld)
    assert g.report["boundary_loops"] == 27
    assert _loops(out_f) == 27


@pytest.mark.slow
@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh", "plane_mesh"])
def test_remeshing_error_within_target(fixture, request):
    """Hausdorff <= 1 % and RMS <= 0.2 % of the bbox diagonal at N = 256 (issue #2)."""
    v, f = request.getfixturevalue(fixture)
    g = mesh_to_geometry_image(v, f, size=256)
    out_v, out_f = geometry_image_to_mesh(g.gim, g.weld)
    d = surface_distance(v, f, out_v, out_f)
    assert d.hausdorff / d.diagonal <= 0.01
    assert d.rms / d.diagonal <= 0.002


def test_finer_grid_is_closer(spot_mesh):
    v, f = spot_mesh
    errors = []
    for size in (64, 256):
        g = mesh_to_geometry_image(v, f, size=size)
        d = surface_distance(v, f, *geometry_image_to_mesh(g.gim, g.weld), samples=50_000)
        errors.append(d.rms)
    assert errors[1] < errors[0]


def test_same_input_same_bytes(spot_mesh, spot_gim):
    again = mesh_to_geometry_image(*spot_mesh, size=128)
    assert again.gim.tobytes() == spot_gim.gim.tobytes()
    assert np.array_equal(again.weld, spot_gim.weld)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_similarity_transform_commutes(spot_mesh, spot_gim, seed):
    """Rotating, translating and scaling the input does the same to the image (issue #2)."""
    v, f = spot_mesh
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(random_state=seed).as_matrix()
    scale = 10.0 ** rng.uniform(-2, 2)
    shift = rng.normal(size=3) * 10
    moved = mesh_to_geometry_image(scale * v @ rotation.T + shift, f, size=128)
    expected = scale * spot_gim.gim @ rotation.T + shift
    diag = bounding_box_diagonal(expected.reshape(-1, 3))
    assert np.abs(moved.gim - expected).max() <= 1e-6 * diag
    assert np.array_equal(moved.weld, spot_gim.weld)


def test_vertex_and_face_order_do_not_matter(spot_mesh, spot_gim):
    v, f = spot_mesh
    rng = np.random.default_rng(7)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    f2 = inverse[f][rng.permutation(len(f))]
    f2 = np.roll(f2, 1, axis=1)  # rotating corners keeps the winding
    g = mesh_to_geometry_image(v[perm], f2, size=128)
    assert_allclose(g.gim, spot_gim.gim, rtol=0, atol=1e-9 * bounding_box_diagonal(v))


def test_other_components_pass_through_unchanged(spot_mesh):
    v, f = spot_mesh
    tet_v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 0.05 + 3.0
    tet_f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    g = mesh_to_geometry_image(np.vstack([v, tet_v]), np.vstack([f, tet_f + len(v)]), size=64)
    assert g.report["components_passed_through"] == 1
    out_v, out_f = geometry_image_to_mesh(
        g.gim, g.weld, other_vertices=g.other_vertices, other_faces=g.other_faces
    )
    assert np.array_equal(out_v[-4:], tet_v)
    assert np.array_equal(out_f[-4:] - (len(out_v) - 4), tet_f)


def test_tetrahedron_is_the_smallest_mesh():
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    g = mesh_to_geometry_image(v, f, size=64)
    out = trimesh.Trimesh(*geometry_image_to_mesh(g.gim, g.weld), process=False)
    assert out.is_watertight
    assert np.isfinite(g.gim).all()


@pytest.mark.parametrize("size", [0, 32, 100, 4096, -256])
def test_bad_size_is_refused(spot_mesh, size):
    with pytest.raises(ValueError, match="size must be a power of two"):
        mesh_to_geometry_image(*spot_mesh, size=size)


def test_bad_size_type_is_refused(spot_mesh):
    with pytest.raises(TypeError, match="size must be an integer"):
        mesh_to_geometry_image(*spot_mesh, size=256.0)


def test_one_triangle_is_refused():
    with pytest.raises(MeshError, match="only 1 faces"):
        mesh_to_geometry_image(np.eye(3), np.array([[0, 1, 2]]), size=64)


def test_inputs_are_not_modified(spot_mesh):
    v, f = spot_mesh
    v0, f0 = v.copy(), f.copy()
    mesh_to_geometry_image(v, f, size=64)
    assert np.array_equal(v, v0) and np.array_equal(f, f0)


def test_gim_shape_is_checked():
    with pytest.raises(ValueError, match="gim must have shape"):
        geometry_image_to_mesh(np.zeros((4, 5, 3)))
