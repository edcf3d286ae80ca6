"""Small meshes for the step modules of the geometry-image stage."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from meshwm.gim.code import grid_faces


@pytest.fixture(scope="module")
def ellipsoid() -> tuple[np.ndarray, np.ndarray]:
    """A closed genus-0 ellipsoid (semi-axes 2, 1, 0.5), 642 vertices."""
    sphere = trimesh.creation.icosphere(subdivisions=3)
    return np.asarray(sphere.vertices) * [2.0, 1.0, 0.5], np.asarray(sphere.faces, np.int64)


@pytest.fixture(scope="module")
def flat_square() -> tuple[np.ndarray, np.ndarray]:
    """The unit square as a 5 × 5 grid of vertices in the plane z = 0 (a disk)."""
    i, j = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    vertices = np.stack([j.ravel() / 4, i.ravel() / 4, np.zeros(25)], axis=1)
    return vertices, grid_faces(5)
