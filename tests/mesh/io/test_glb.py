"""Tests for :mod:`meshwm.mesh.io.glb`: GLB files and scenes, read like trimesh's ``Scene.dump``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from _io_checks import sorted_rows, triangle_rows

from meshwm.mesh.io import read_mesh


@pytest.fixture(scope="module")
def spot(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return spot_mesh


def test_glb_single_mesh(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    path = tmp_path / "spot.glb"
    path.write_bytes(trimesh.Trimesh(vertices, faces, process=False).export(file_type="glb"))
    read_vertices, read_faces = read_mesh(path)
    np.testing.assert_array_equal(read_faces, faces)
    np.testing.assert_array_equal(read_vertices, vertices.astype(np.float32))  # GLB is float32


def test_glb_scene_is_concatenated_with_transforms(tmp_path: Path) -> None:
    box = trimesh.creation.box()
    ico = trimesh.creation.icosahedron()
    scene = trimesh.Scene()
    scene.add_geometry(box, transform=trimesh.transformations.translation_matrix([10, 0, 0]))
    scene.add_geometry(ico)
    path = tmp_path / "scene.glb"
    path.write_bytes(scene.export(file_type="glb"))
    vertices, faces = read_mesh(path)
    assert len(vertices) == len(box.vertices) + len(ico.vertices)
    assert len(faces) == len(box.faces) + len(ico.faces)
    moved_box = box.vertices + np.array([10.0, 0.0, 0.0])
    expected = np.concatenate([moved_box[box.faces], ico.vertices[ico.faces]])
    np.testing.assert_allclose(
        triangle_rows(vertices, faces), sorted_rows(expected.reshape(len(faces), 9)), atol=1e-6
    )


def test_glb_instances_read_like_trimesh_dump(tmp_path: Path) -> None:
    """Rotated, scaled and mirrored instances: the same arrays as trimesh's ``Scene.dump``
    (which read_mesh no longer calls, for speed), mirrored winding reversed included."""
    ico = trimesh.creation.icosahedron()
    scene = trimesh.Scene()
    rotate = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0], [0.5, 0.0, 0.0])
    mirror = np.diag([-2.0, 1.0, 1.0, 1.0])
    mirror[:3, 3] = [0.0, 5.0, 0.0]
    for transform in (rotate, mirror, np.eye(4)):
        scene.add_geometry(ico, transform=transform)
    path = tmp_path / "instances.glb"
    path.write_bytes(scene.export(file_type="glb"))
    vertices, faces = read_mesh(path)
    loaded = trimesh.load_scene(path, process=False)
    dumped = [m for m in loaded.dump() if isinstance(m, trimesh.Trimesh)]
    expected_v = np.concatenate([m.vertices for m in dumped])
    offsets = np.cumsum([0] + [len(m.vertices) for m in dumped[:-1]])
    expected_f = np.concatenate([m.faces + k for m, k in zip(dumped, offsets, strict=True)])
    np.testing.assert_allclose(vertices, expected_v, atol=1e-12)
    np.testing.assert_array_equal(faces, expected_f)
    # The mirrored copy's normals still point outwards: winding reversed, not inside out.
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.volume > 0
