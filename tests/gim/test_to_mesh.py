"""Tests for :mod:`meshwm.gim.to_mesh`: a geometry image back to a mesh, seams welded."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh
from meshwm.mesh.clean import edge_topology_counts


def _loops(faces: np.ndarray) -> int:
    mesh = trimesh.Trimesh(np.zeros((faces.max() + 1, 3)), faces, process=False)
    return len(
        trimesh.graph.connected_components(
            mesh.edges[trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)]
        )
    )


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


def test_gim_shape_is_checked():
    with pytest.raises(ValueError, match="gim must have shape"):
        geometry_image_to_mesh(np.zeros((4, 5, 3)))


@pytest.mark.parametrize("fixture", ["spot_mesh", "kitten_mesh", "plane_mesh"])
def test_fins_found_among_the_seams_triangles_are_all_of_them(fixture, request):
    # The welded grid's repeated triangles are looked for only among the triangles at a
    # welded sample's root: the same triangles dropped as a search over all of them.
    from meshwm.gim.code import grid_faces
    from meshwm.gim.to_mesh import _weld_faces

    v, f = request.getfixturevalue(fixture)
    g = mesh_to_geometry_image(v, f, size=64)
    faces = g.weld.reshape(-1)[grid_faces(64)]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])]
    faces = faces[faces[:, 0] != faces[:, 2]]
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    expected = faces[counts[inverse] == 1]
    np.testing.assert_array_equal(_weld_faces(grid_faces(64), g.weld), expected)


def _random_weld(n: int, rng: np.random.Generator, count: int) -> np.ndarray:
    """An idempotent weld map: ``count`` samples welded to other samples (roots), many of them
    to a neighbour (their triangles collapse) and some in mirrored runs along the border, as a
    cut's two sides are (their end triangles become fins)."""
    root = np.arange(n * n)
    samples = rng.choice(n * n, size=count, replace=False)
    for k in samples:
        i, j = divmod(int(k), n)
        di, dj = rng.integers(-1, 2, size=2)
        target = (
            int(np.clip(i + di, 0, n - 1)) * n + int(np.clip(j + dj, 0, n - 1))
            if rng.random() < 0.7
            else int(rng.integers(n * n))
        )
        if root[target] == target and target != k:
            root[k] = target
    side = n // 2
    for t in range(1, side):  # the top border's right half folded onto its left half
        a, b = side - t, side + t
        if root[a] == a and root[b] == b:
            root[b] = a
    return root[root].reshape(n, n)  # idempotent


@pytest.mark.parametrize("n", [4, 16, 64, 256])
def test_welding_the_grid_from_its_seams_is_welding_every_triangle(n, spot_mesh):
    # geometry_image_to_mesh welds the grid from the triangles around its welded samples:
    # the same faces, row for row, as the weld of every triangle (random welds with collapsed
    # triangles and fins, and a real geometry image's seams).
    from meshwm.gim.code import grid_faces
    from meshwm.gim.to_mesh import _weld_faces, _welded_grid_faces

    rng = np.random.default_rng(n)
    welds = [_random_weld(n, rng, count) for count in (0, 1, n, n * n // 4)]
    if n >= 64:
        v, f = spot_mesh
        welds.append(mesh_to_geometry_image(v, f, size=n).weld)
    for weld in welds:
        want = _weld_faces(grid_faces(n), weld)
        got = _welded_grid_faces(n, weld)
        assert got.dtype == np.int64
        np.testing.assert_array_equal(got, want)
    assert any(len(_weld_faces(grid_faces(n), w)) < len(grid_faces(n)) for w in welds)
