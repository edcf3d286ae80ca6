"""Fixtures of the :mod:`meshwm.attacks` tests: spot as given and as a meshwm grid mesh."""

from __future__ import annotations

import numpy as np
import pytest
from _attack_checks import spot_gim_mesh


@pytest.fixture(scope="module")
def mesh(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The bundled spot mesh, as read."""
    return spot_mesh


@pytest.fixture(scope="module")
def gim_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A geometry-image mesh as meshwm writes it (N = 64, cut seams welded)."""
    return spot_gim_mesh()
