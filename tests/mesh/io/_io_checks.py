"""Helpers of the mesh I/O tests: the assets folder, triangle comparisons, the error shape.

No conftest.py here: with ``--doctest-modules`` pytest imports every conftest.py as a module
named ``conftest``, and two of them outside packages collide; the fixtures are in the modules.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from meshwm.errors import MeshError

ASSETS = Path(__file__).parent.parent.parent.parent / "assets"


def sorted_rows(rows: np.ndarray) -> np.ndarray:
    """Rows in lexicographic order (compare sets of triangles regardless of order)."""
    return rows[np.lexsort(rows.T[::-1])]


def triangle_rows(vertices: np.ndarray, faces: np.ndarray, dtype: type = np.float64) -> np.ndarray:
    """Un-indexed triangles as sorted ``(m, 9)`` rows of corner coordinates."""
    return sorted_rows(vertices[faces].astype(dtype).reshape(len(faces), 9))


def assert_one_line_error(error: pytest.ExceptionInfo[MeshError], path: Path) -> None:
    message = str(error.value)
    assert "\n" not in message and "\r" not in message
    assert message.startswith(f"{path}: ")
    assert path.name in message
