"""Tests for :mod:`meshwm.mesh.io.read`: reading valid files and refusing malformed ones.

The malformed files come from ``tests/_malformed.py`` (built from ``assets/*.ply`` and from
generated text, deterministically).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from _io_checks import ASSETS, assert_one_line_error
from _malformed import CASE_IDS, MUST_FAIL_ON_READ_IDS, MalformedCase, make_malformed_cases

import meshwm.mesh.io.common as mio_common
from meshwm.errors import MeshError
from meshwm.mesh.io import read_mesh

ASSET_COUNTS = {"spot": (2930, 5856), "kitten": (9447, 18894), "plane_holes": (8519, 16747)}
READABLE_LATER_IDS = tuple(i for i in CASE_IDS if i not in MUST_FAIL_ON_READ_IDS)


# --------------------------------------------------------------------------------------------
# malformed files
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="session")
def malformed_cases(tmp_path_factory: pytest.TempPathFactory) -> dict[str, MalformedCase]:
    cases = make_malformed_cases(tmp_path_factory.mktemp("malformed"))
    return {case.case_id: case for case in cases}


@pytest.fixture(scope="module")
def spot(spot_mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    return spot_mesh


def test_malformed_case_list(malformed_cases: dict[str, MalformedCase]) -> None:
    assert tuple(malformed_cases) == CASE_IDS
    assert len(CASE_IDS) >= 60
    assert len(set(CASE_IDS)) == len(CASE_IDS)
    assert set(READABLE_LATER_IDS) == {
        "later_one_face_obj",
        "later_one_face_ply",
        "later_nonmanifold_fan_obj",
        "later_nonmanifold_fan_off",
        "later_degenerate_triangle_obj",
    }


@pytest.mark.parametrize("case_id", MUST_FAIL_ON_READ_IDS)
def test_malformed_file_raises_mesh_error(
    case_id: str, malformed_cases: dict[str, MalformedCase], capfd: pytest.CaptureFixture[str]
) -> None:
    case = malformed_cases[case_id]
    with pytest.raises(MeshError) as error:
        read_mesh(case.path)
    assert_one_line_error(error, case.path)
    captured = capfd.readouterr()
    assert captured.out == "" and captured.err == ""  # no trimesh log noise


@pytest.mark.parametrize("case_id", READABLE_LATER_IDS)
def test_readable_cases_rejected_only_later(
    case_id: str, malformed_cases: dict[str, MalformedCase]
) -> None:
    vertices, faces = read_mesh(malformed_cases[case_id].path)
    assert vertices.dtype == np.float64 and vertices.ndim == 2 and vertices.shape[1] == 3
    assert faces.dtype == np.int64 and faces.ndim == 2 and faces.shape[1] == 3
    assert 1 <= len(faces) <= 4
    assert faces.min() >= 0 and faces.max() < len(vertices)


def test_missing_file_message(tmp_path: Path) -> None:
    with pytest.raises(MeshError, match="no such file"):
        read_mesh(tmp_path / "nope.obj")


def test_directory_message(tmp_path: Path) -> None:
    (tmp_path / "dir.stl").mkdir()
    with pytest.raises(MeshError, match="is a directory"):
        read_mesh(tmp_path / "dir.stl")


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can read any file"
)
def test_unreadable_file(tmp_path: Path) -> None:
    path = tmp_path / "secret.ply"
    path.write_bytes((ASSETS / "spot.ply").read_bytes())
    path.chmod(0)
    with pytest.raises(MeshError, match="cannot read file") as error:
        read_mesh(path)
    assert_one_line_error(error, path)


def test_read_error_is_converted(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "locked.obj"
    path.write_text("v 0 0 0\n")

    def deny(*args: object, **kwargs: object) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(mio_common, "open", deny, raising=False)  # shadows the builtin there
    with pytest.raises(MeshError, match=r"cannot read file \(Permission denied\)") as error:
        read_mesh(path)
    assert_one_line_error(error, path)


# --------------------------------------------------------------------------------------------
# reading valid files
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(ASSET_COUNTS))
def test_assets_read_exactly(name: str) -> None:
    path = ASSETS / f"{name}.ply"
    vertices, faces = read_mesh(path)
    assert (len(vertices), len(faces)) == ASSET_COUNTS[name]
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    reference = trimesh.load(path, process=False)
    np.testing.assert_array_equal(vertices, reference.vertices)
    np.testing.assert_array_equal(faces, reference.faces)


def test_read_accepts_str_path_and_uppercase_suffix(tmp_path: Path) -> None:
    path = tmp_path / "SPOT.PLY"
    path.write_bytes((ASSETS / "spot.ply").read_bytes())
    vertices, faces = read_mesh(str(path))
    assert (len(vertices), len(faces)) == ASSET_COUNTS["spot"]


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".stl", ".glb", ".off"])
def test_max_faces_limit(suffix: str, tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    path = tmp_path / f"spot{suffix}"
    data = trimesh.Trimesh(vertices, faces, process=False).export(file_type=suffix[1:])
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    n = len(faces)
    assert len(read_mesh(path, max_faces=n)[1]) == n
    with pytest.raises(MeshError, match=f"{n} .*more than the limit of {n - 1}") as error:
        read_mesh(path, max_faces=n - 1)
    assert_one_line_error(error, path)


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "10"])
def test_max_faces_must_be_positive_int(bad: object) -> None:
    with pytest.raises((TypeError, ValueError)):
        read_mesh(ASSETS / "spot.ply", max_faces=bad)  # type: ignore[arg-type]
