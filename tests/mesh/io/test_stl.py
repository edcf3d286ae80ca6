"""Tests for :mod:`meshwm.mesh.io.stl`: STL is written as float32, one vertex triple per face."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _io_checks import triangle_rows

from meshwm.mesh.io import read_mesh, write_mesh


@pytest.fixture(scope="module")
def spot(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return spot_mesh


def test_round_trip_stl_float32(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    path = tmp_path / "out.stl"
    write_mesh(path, vertices, faces)
    read_vertices, read_faces = read_mesh(path)
    assert len(read_faces) == len(faces)

    np.testing.assert_array_equal(
        triangle_rows(read_vertices, read_faces, np.float32),
        triangle_rows(vertices, faces, np.float32),
    )
