"""Shared fixtures: the bundled meshes, read once per session."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from meshwm.mesh.io import read_mesh

ASSETS = Path(__file__).parent.parent / "assets"

#: Fixtures of sub-trees live in plugin modules next to this file: pytest's --doctest-modules
#: imports every conftest.py under the name ``conftest``, so a second one would collide.
pytest_plugins = [
    "_fixtures_attacks",
    "_fixtures_bench",
    "_fixtures_cutmap",
    "_fixtures_gim",
    "_fixtures_recover",
    "_fixtures_registry",
]


@pytest.fixture(autouse=True, scope="session")
def _no_key_in_the_environment() -> Iterator[None]:
    """A ``MESHWM_KEY`` exported in the shell that runs the tests would make every ``--key``
    a second key source (refused); tests that want the variable set it themselves."""
    with pytest.MonkeyPatch.context() as patch:
        patch.delenv("MESHWM_KEY", raising=False)
        yield


@pytest.fixture(scope="session")
def assets_dir() -> Path:
    return ASSETS


@pytest.fixture(scope="session")
def spot_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Closed genus-0 cow (public domain, Keenan Crane)."""
    return read_mesh(ASSETS / "spot.ply")


@pytest.fixture(scope="session")
def kitten_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Closed genus-1 kitten."""
    return read_mesh(ASSETS / "kitten.ply")


@pytest.fixture(scope="session")
def plane_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Open plane with 27 cut-out windows."""
    return read_mesh(ASSETS / "plane_holes.ply")


@pytest.fixture(scope="session")
def slid_rim() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A flat annulus (16 vertices a ring, the hole's radius 0.3), and its hole's rim with each
    vertex slid half a step along the rim's circle: every vertex stays on the other surface,
    but each rim edge, a chord, now spans the hole (its midpoint 0.2 % of the diagonal away)."""
    k, radii = 16, np.linspace(0.3, 1.0, 6)
    turn = 2 * np.pi * np.arange(k) / k
    v = np.array([[r * np.cos(a), r * np.sin(a), 0.0] for r in radii for a in turn])
    f = []
    for ring in range(len(radii) - 1):
        for j in range(k):
            a, b = ring * k + j, ring * k + (j + 1) % k
            f += [(a, b, b + k), (a, b + k, a + k)]
    slid = v.copy()
    half = turn + np.pi / k
    slid[:k] = np.stack([0.3 * np.cos(half), 0.3 * np.sin(half), np.zeros(k)], axis=1)
    return v, np.array(f, dtype=np.int64), slid
