"""Tests for :mod:`meshwm.mesh.io.ply`: the header pre-check against the size of the file."""

from __future__ import annotations

from pathlib import Path

import pytest
from _io_checks import ASSETS

from meshwm.errors import MeshError
from meshwm.mesh.io import read_mesh


def test_max_faces_checked_before_loading_absurd_header(tmp_path: Path) -> None:
    data = (ASSETS / "spot.ply").read_bytes().replace(b"face 5856", b"face 4000000000", 1)
    path = tmp_path / "absurd.ply"
    path.write_bytes(data)
    with pytest.raises(MeshError, match=r"needs at least 4000070320 bytes .* has 146448"):
        read_mesh(path, max_faces=10**12)  # the size of the file gives it away
