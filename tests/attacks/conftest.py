"""Fixtures of the attack tests: spot, and a geometry-image mesh of it as meshwm writes it."""

from __future__ import annotations

import pytest
from _attack_checks import GIM

from meshwm.attacks import ATTACKS
from meshwm.gim.remesh import geometry_image_to_mesh, mesh_to_geometry_image


@pytest.fixture(scope="session")
def mesh(spot_mesh):
    return spot_mesh


@pytest.fixture(scope="session")
def gim_mesh(spot_mesh):
    """A geometry-image mesh as meshwm writes it (N = 64, cut seams welded)."""
    g = mesh_to_geometry_image(*spot_mesh, size=64)
    return geometry_image_to_mesh(g.gim, g.weld)


@pytest.fixture(scope="session")
def meshes(mesh, gim_mesh):
    """The input each attack is tested on."""
    return {name: gim_mesh if name in GIM else mesh for name in ATTACKS}
