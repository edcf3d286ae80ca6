"""Tests for :mod:`meshwm.mesh.asset.document`: welding a file's position rows into vertices."""

from __future__ import annotations

import numpy as np

from meshwm.mesh.asset.document import group_sections, weld_rows


def _reference(positions, rows):
    """The definition: rows sorted and unique; equal positions (as floats) one vertex,
    numbered by their first row."""
    rows = np.unique(rows)
    key = [tuple(float(x) + 0.0 for x in positions[r]) for r in rows]
    number: dict[tuple, int] = {}
    return rows, np.array([number.setdefault(k, len(number)) for k in key], dtype=np.int64)


def test_weld_rows_matches_its_definition_on_random_tables():
    rng = np.random.default_rng(3)
    for trial in range(300):
        n = int(rng.integers(1, 120))
        if trial % 2:
            p = rng.integers(-2, 3, size=(n, 3)) * rng.choice([1.0, -1.0], size=(n, 3))  # ±0.0
            p = p.astype(float) * rng.choice([1.0, 0.0, -0.0], size=(n, 3))
        else:
            p = rng.normal(size=(n, 3))
            p[rng.integers(0, n, n // 2)] = p[rng.integers(0, n)]
        rows = rng.integers(0, n, size=int(rng.integers(1, 3 * n)))
        got, vertex = weld_rows(p, rows)
        want, want_vertex = _reference(p, rows)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(vertex, want_vertex)


def test_a_file_without_duplicates_keeps_its_vertex_order():
    p = np.random.default_rng(0).normal(size=(50, 3))
    rows, vertex = weld_rows(p, np.arange(50)[::-1])
    np.testing.assert_array_equal(rows, np.arange(50))
    np.testing.assert_array_equal(vertex, np.arange(50))


def test_sections_sharing_a_row_are_one_mesh_and_refer_to_their_vertices():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [5, 5, 5], [6, 5, 5], [5, 6, 5]])
    sections = [
        ("a", np.array([[0, 1, 2]]), 1),
        ("b", np.array([[1, 3, 2]]), 1),
        ("c", np.array([[4, 5, 6]]), 1),
    ]
    meshes = group_sections(p, sections)
    assert [m.name for m in meshes] == ["a+b", "c"]
    triangles = [np.array([[0, 1, 2], [1, 3, 2]]), np.array([[4, 5, 6]])]
    for mesh, tri in zip(meshes, triangles, strict=True):
        vertices = np.empty((int(mesh.vertex_of_row.max()) + 1, 3))
        vertices[mesh.vertex_of_row] = p[mesh.rows]
        np.testing.assert_array_equal(vertices[mesh.faces], p[tri])
