"""Tests for :mod:`meshwm.mesh.io.obj`: OBJ records trimesh would skip, polygons, indices."""

from __future__ import annotations

from pathlib import Path

from meshwm.mesh.io import read_mesh


def test_obj_quads_and_polygons_are_triangulated(tmp_path: Path) -> None:
    path = tmp_path / "quads.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nv 9 9 9\n"
        "f 1 2 3 4\nf 4 3 5\n"  # a quad, a triangle; vertex 6 is unreferenced
    )
    vertices, faces = read_mesh(path)
    assert len(vertices) == 6  # unreferenced vertex kept, nothing merged
    assert faces.tolist() == [[0, 1, 2], [2, 3, 0], [3, 2, 4]]


def test_obj_indented_and_tab_separated_records(tmp_path: Path) -> None:
    """trimesh alone silently skips these lines (dropping a vertex shifts every index)."""
    path = tmp_path / "whitespace.obj"
    path.write_text("v 0 0 0\n  v 1 0 0\nv\t0 1 0\n\tv 1 1 1\n f 1 2 3\nf\t1 3 4\n")
    vertices, faces = read_mesh(path)
    assert vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]]
    assert faces.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_obj_negative_relative_indices(tmp_path: Path) -> None:
    path = tmp_path / "relative.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n")
    assert read_mesh(path)[1].tolist() == [[0, 1, 2]]
