"""Fixtures of the :mod:`meshwm.gim.recover` tests: the meshes meshwm writes, built once."""

from __future__ import annotations

import numpy as np
import pytest
from _recover_grids import SIZE, synthetic_gim

from meshwm.gim.remesh import mesh_to_geometry_image
from meshwm.gim.to_mesh import geometry_image_to_mesh


@pytest.fixture(scope="session")
def welded(request):
    """(GeometryImage, vertices, faces) of each bundled mesh at N = 128, built once."""
    cache = {}

    def get(name):
        if name not in cache:
            g = mesh_to_geometry_image(*request.getfixturevalue(name), size=SIZE)
            cache[name] = (g, *geometry_image_to_mesh(g.gim, g.weld))
        return cache[name]

    return get


@pytest.fixture(scope="session")
def open_grid():
    gim = synthetic_gim(64)
    v, f = geometry_image_to_mesh(gim)
    return gim, v, f


@pytest.fixture(scope="session")
def sheet():
    """The open synthetic grid at N = 64 with its index (row-major: sample k is vertex k)."""
    gim = synthetic_gim(64)
    v, f = geometry_image_to_mesh(gim)
    return v, f, np.arange(64 * 64).reshape(64, 64)
