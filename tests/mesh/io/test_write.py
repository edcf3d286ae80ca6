"""Tests for :mod:`meshwm.mesh.io.write`: exact, deterministic, atomic writing and its refusals."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from _io_checks import ASSETS, assert_one_line_error

from meshwm.errors import MeshError
from meshwm.mesh.io import WRITE_SUFFIXES, check_output_suffix, read_mesh, write_mesh
from meshwm.mesh.io.registry import WRITERS

# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def spot(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return spot_mesh


def _awkward_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Floats across the whole float64 range, signed zeros and an unreferenced vertex."""
    rng = np.random.default_rng(20240611)
    vertices = rng.standard_normal((300, 3)) * 10.0 ** rng.integers(-300, 300, (300, 3))
    vertices[0] = [5e-324, -0.0, 1.7976931348623157e308]
    vertices[1] = [0.1, 1 / 3, -2.0 / 7]
    faces = rng.integers(0, 299, (400, 3))  # vertex 299 unreferenced
    return vertices, faces


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".off"])
@pytest.mark.parametrize("mesh", ["spot", "awkward"])
def test_round_trip_is_exact(
    suffix: str, mesh: str, tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]
) -> None:
    vertices, faces = spot if mesh == "spot" else _awkward_mesh()
    path = tmp_path / f"out{suffix}"
    write_mesh(path, vertices, faces)
    read_vertices, read_faces = read_mesh(path)
    assert np.array_equal(read_vertices, vertices)
    assert np.array_equal(read_vertices.view(np.int64), vertices.view(np.int64))  # -0.0 too
    assert np.array_equal(read_faces, faces)


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".stl", ".PLY", ".off", ".glb"])
def test_output_is_deterministic(
    suffix: str, tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]
) -> None:
    vertices, faces = spot
    write_mesh(tmp_path / f"a{suffix}", vertices, faces)
    write_mesh(tmp_path / f"b{suffix}", vertices.copy(), faces.copy())
    first = (tmp_path / f"a{suffix}").read_bytes()
    assert first == (tmp_path / f"b{suffix}").read_bytes()
    assert len(first) > 50_000
    assert b"meshwm" not in first and b"trimesh" not in first  # no file names a tool


def test_glb_round_trip_is_float32(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    write_mesh(tmp_path / "x.glb", vertices, faces)
    read_vertices, read_faces = read_mesh(tmp_path / "x.glb")
    assert np.array_equal(read_vertices, vertices.astype(np.float32))
    assert np.array_equal(read_faces, faces)


def test_write_does_not_modify_inputs(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = (a.copy() for a in spot)
    vertices.flags.writeable = False
    faces.flags.writeable = False
    write_mesh(tmp_path / "x.obj", vertices, faces)
    assert np.array_equal(vertices, spot[0]) and np.array_equal(faces, spot[1])


def test_unknown_output_suffix(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    assert WRITE_SUFFIXES == (".glb", ".obj", ".off", ".ply", ".stl")
    check_output_suffix(tmp_path / "fine.STL")
    for name in ("mesh.fbx", "mesh.gltf", "mesh"):
        with pytest.raises(MeshError, match=r"valid output suffixes are \.glb, \.obj, \.off, "):
            check_output_suffix(tmp_path / name)
    with pytest.raises(MeshError, match=r"'\.xyz'") as error:
        write_mesh(tmp_path / "mesh.xyz", *spot)
    assert_one_line_error(error, tmp_path / "mesh.xyz")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("vertices", "faces", "match"),
    [
        ([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], [[0, 1, 2]], "NaN"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], "face indices"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((0, 3), int), "no faces"),
    ],
)
def test_write_rejects_invalid_arrays(
    vertices: list, faces: list, match: str, tmp_path: Path
) -> None:
    path = tmp_path / "bad.ply"
    with pytest.raises(MeshError, match=match) as error:
        write_mesh(path, np.asarray(vertices, float), faces)
    assert_one_line_error(error, path)
    assert list(tmp_path.iterdir()) == []


def _fail(*args: object, **kwargs: object) -> None:
    raise OSError(28, "No space left on device")


def _crash(*args: object, **kwargs: object) -> None:
    raise RuntimeError("exporter crashed")


@pytest.mark.parametrize("step", ["serialise", "fsync", "replace"])
@pytest.mark.parametrize("existing", [False, True])
def test_write_is_atomic(
    step: str,
    existing: bool,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    spot: tuple[np.ndarray, np.ndarray],
) -> None:
    path = tmp_path / "out.ply"
    if existing:
        path.write_bytes(b"previous content")
    if step == "serialise":
        monkeypatch.setitem(WRITERS, ".ply", _crash)
        expected: type[Exception] = RuntimeError  # a bug, not a bad file: propagates unchanged
    else:
        monkeypatch.setattr(os, step, _fail)
        expected = MeshError
    with pytest.raises(expected):
        write_mesh(path, *spot)
    monkeypatch.undo()
    remaining = sorted(p.name for p in tmp_path.iterdir())
    if existing:
        assert remaining == ["out.ply"] and path.read_bytes() == b"previous content"
    else:
        assert remaining == []


def test_write_failure_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, spot: tuple[np.ndarray, np.ndarray]
) -> None:
    path = tmp_path / "out.obj"
    monkeypatch.setattr(os, "replace", _fail)
    with pytest.raises(MeshError, match="No space left on device") as error:
        write_mesh(path, *spot)
    assert_one_line_error(error, path)


def test_write_into_missing_directory(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    path = tmp_path / "missing" / "out.ply"
    with pytest.raises(MeshError, match=r"folder .* does not exist") as error:
        write_mesh(path, *spot)
    assert_one_line_error(error, path)


def test_write_onto_directory_leaves_no_temp_file(
    tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]
) -> None:
    (tmp_path / "taken.ply").mkdir()
    with pytest.raises(MeshError, match="cannot write file"):
        write_mesh(tmp_path / "taken.ply", *spot)
    assert [p.name for p in tmp_path.iterdir()] == ["taken.ply"]


def test_refuses_to_overwrite_input_without_force(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    original = (ASSETS / "spot.ply").read_bytes()
    source = tmp_path / "in.ply"
    source.write_bytes(original)
    (tmp_path / "link.ply").symlink_to(source)
    vertices, faces = read_mesh(source)
    moved = vertices + 1.0
    monkeypatch.chdir(tmp_path)
    for target in (source, Path("in.ply"), tmp_path / "link.ply", tmp_path / "." / "in.ply"):
        with pytest.raises(MeshError, match="would overwrite the input; use --force") as error:
            write_mesh(target, moved, faces, overwrite_input=source)
        assert_one_line_error(error, target)
        assert source.read_bytes() == original
    write_mesh(source, moved, faces, overwrite_input=source, force=True)
    assert np.array_equal(read_mesh(source)[0], moved)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.ply", "link.ply"]


def test_other_output_next_to_input_is_allowed(tmp_path: Path) -> None:
    source = tmp_path / "in.ply"
    source.write_bytes((ASSETS / "spot.ply").read_bytes())
    write_mesh(tmp_path / "out.ply", *read_mesh(source), overwrite_input=source)
    assert (tmp_path / "out.ply").is_file()


def test_file_permissions(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    fresh = tmp_path / "fresh.obj"
    write_mesh(fresh, *spot)
    umask = os.umask(0o022)
    os.umask(umask)
    assert fresh.stat().st_mode & 0o777 == 0o666 & ~umask
    kept = tmp_path / "kept.ply"
    kept.write_bytes(b"x")
    kept.chmod(0o640)
    write_mesh(kept, *spot)
    assert kept.stat().st_mode & 0o777 == 0o640
