"""Tests for :mod:`meshwm.mesh.io.registry`: the suffixes, their readers and writers, and that
importing :mod:`meshwm.mesh.io` loads no mesh library.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from meshwm.errors import MeshError
from meshwm.mesh.io import READ_SUFFIXES, WRITE_SUFFIXES, read_mesh
from meshwm.mesh.io.registry import READERS, WRITERS, reader_for


def test_unknown_input_suffix_lists_valid_ones(tmp_path: Path) -> None:
    path = tmp_path / "mesh.xyz"
    path.write_bytes(b"0 0 0\n")
    with pytest.raises(MeshError, match=r"'\.xyz'.*\.glb, \.obj, \.off, \.ply, \.stl"):
        read_mesh(path)
    assert READ_SUFFIXES == (".glb", ".obj", ".off", ".ply", ".stl")


def test_every_suffix_has_a_lower_case_entry() -> None:
    assert READ_SUFFIXES == tuple(sorted(READERS))
    assert WRITE_SUFFIXES == tuple(sorted(WRITERS))
    assert set(WRITE_SUFFIXES) <= set(READ_SUFFIXES)  # what is written can be read back
    for suffix, reader in READERS.items():
        assert suffix == suffix.lower() and suffix.startswith(".")
        assert reader.file_type == suffix[1:] and reader.label == reader.file_type.upper()


@pytest.mark.parametrize("name", ["Mesh.OBJ", "mesh.ply", "a.b.Stl"])
def test_reader_for_ignores_case(name: str) -> None:
    assert reader_for(name) is READERS[Path(name).suffix.lower()]


def test_reader_for_a_name_without_suffix(tmp_path: Path) -> None:
    with pytest.raises(MeshError, match=r"file name has no suffix; valid suffixes are \.glb, "):
        reader_for(tmp_path / "mesh")


HEAVY = ("trimesh", "igl", "pymeshlab", "scipy", "PIL")


def test_importing_the_package_loads_no_mesh_library() -> None:
    """The registry and the suffix lists come without trimesh; it is loaded on first read."""
    code = (
        "import sys, meshwm.mesh.io; "
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r}))"
    )
    root = Path(__file__).parent.parent.parent.parent
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=root, env=env, check=True
    )
    assert out.stdout.strip() == "[]"
