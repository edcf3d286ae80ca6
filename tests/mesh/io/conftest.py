"""Fixtures of the mesh I/O tests: the malformed files and the spot mesh."""

from __future__ import annotations

import numpy as np
import pytest
from _malformed import MalformedCase, make_malformed_cases


@pytest.fixture(scope="session")
def malformed_cases(tmp_path_factory: pytest.TempPathFactory) -> dict[str, MalformedCase]:
    cases = make_malformed_cases(tmp_path_factory.mktemp("malformed"))
    return {case.case_id: case for case in cases}


@pytest.fixture(scope="session")
def spot(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The bundled spot mesh (``assets/spot.ply``), read once."""
    return spot_mesh
