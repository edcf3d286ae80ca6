"""Tests for :mod:`meshwm.mesh.io`: reading, writing and refusing malformed mesh files.

The malformed files come from ``tests/_malformed.py`` (built from ``assets/*.ply`` and from
generated text, deterministically).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from _malformed import CASE_IDS, MUST_FAIL_ON_READ_IDS, MalformedCase, make_malformed_cases

import meshwm.mesh.io as mio
from meshwm.errors import MeshError
from meshwm.mesh.io import READ_SUFFIXES, WRITE_SUFFIXES, check_output_suffix, read_mesh, write_mesh

ASSETS = Path(__file__).parent.parent.parent / "assets"
ASSET_COUNTS = {"spot": (2930, 5856), "kitten": (9447, 18894), "plane_holes": (8519, 16747)}
READABLE_LATER_IDS = tuple(i for i in CASE_IDS if i not in MUST_FAIL_ON_READ_IDS)


@pytest.fixture(scope="session")
def malformed_cases(tmp_path_factory: pytest.TempPathFactory) -> dict[str, MalformedCase]:
    cases = make_malformed_cases(tmp_path_factory.mktemp("malformed"))
    return {case.case_id: case for case in cases}


@pytest.fixture(scope="session")
def spot() -> tuple[np.ndarray, np.ndarray]:
    return read_mesh(ASSETS / "spot.ply")


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


# --------------------------------------------------------------------------------------------
# malformed files
# --------------------------------------------------------------------------------------------


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

    monkeypatch.setattr(mio, "open", deny, raising=False)  # shadows the builtin in meshwm.mesh.io
    with pytest.raises(MeshError, match=r"cannot read file \(Permission denied\)") as error:
        read_mesh(path)
    assert_one_line_error(error, path)


def test_unknown_input_suffix_lists_valid_ones(tmp_path: Path) -> None:
    path = tmp_path / "mesh.xyz"
    path.write_bytes(b"0 0 0\n")
    with pytest.raises(MeshError, match=r"'\.xyz'.*\.glb, \.obj, \.off, \.ply, \.stl"):
        read_mesh(path)
    assert READ_SUFFIXES == (".glb", ".obj", ".off", ".ply", ".stl")


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


def test_obj_quads_and_polygons_are_triangulated(tmp_path: Path) -> None:
    path = tmp_path / "quads.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 1.5 0\nv 9 9 9\n"
        "f 1 2 3 4\nf 4 3 5\n"  # a quad, a triangle; vertex 6 is unreferenced
    )
    vertices, faces = read_mesh(path)
    assert len(vertices) == 6  # unreferenced vertex kept, nothing merged
    assert faces.tolist() == [[0, 1, 2], [2, 3, 0], [3, 2, 4]]


def test_obj_indented_and_tab_separated_records(tmp_path: Path) -> None:
    """trimesh alone silently skips these lines (dropping a vertex shifts every index)."""
    path = tmp_path / "whitespace.obj"
    path.write_text("v 0 0 0\n  v 1 0 0\nv\t0 1 0\n\tv 1 1 1\n f 1 2 3\nf\t1 3 4\n")
    vertices, faces = read_mesh(path)
    assert vertices.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]]
    assert faces.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_obj_negative_relative_indices(tmp_path: Path) -> None:
    path = tmp_path / "relative.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n")
    assert read_mesh(path)[1].tolist() == [[0, 1, 2]]


def test_glb_single_mesh(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    path = tmp_path / "spot.glb"
    path.write_bytes(trimesh.Trimesh(vertices, faces, process=False).export(file_type="glb"))
    read_vertices, read_faces = read_mesh(path)
    np.testing.assert_array_equal(read_faces, faces)
    np.testing.assert_array_equal(read_vertices, vertices.astype(np.float32))  # GLB is float32


def test_glb_scene_is_concatenated_with_transforms(tmp_path: Path) -> None:
    box = trimesh.creation.box()
    ico = trimesh.creation.icosahedron()
    scene = trimesh.Scene()
    scene.add_geometry(box, transform=trimesh.transformations.translation_matrix([10, 0, 0]))
    scene.add_geometry(ico)
    path = tmp_path / "scene.glb"
    path.write_bytes(scene.export(file_type="glb"))
    vertices, faces = read_mesh(path)
    assert len(vertices) == len(box.vertices) + len(ico.vertices)
    assert len(faces) == len(box.faces) + len(ico.faces)
    moved_box = box.vertices + np.array([10.0, 0.0, 0.0])
    expected = np.concatenate([moved_box[box.faces], ico.vertices[ico.faces]])
    np.testing.assert_allclose(
        triangle_rows(vertices, faces), sorted_rows(expected.reshape(len(faces), 9)), atol=1e-6
    )


def test_glb_instances_read_like_trimesh_dump(tmp_path: Path) -> None:
    """Rotated, scaled and mirrored instances: the same arrays as trimesh's ``Scene.dump``
    (which read_mesh no longer calls, for speed), mirrored winding reversed included."""
    ico = trimesh.creation.icosahedron()
    scene = trimesh.Scene()
    rotate = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0], [0.5, 0.0, 0.0])
    mirror = np.diag([-2.0, 1.0, 1.0, 1.0])
    mirror[:3, 3] = [0.0, 5.0, 0.0]
    for transform in (rotate, mirror, np.eye(4)):
        scene.add_geometry(ico, transform=transform)
    path = tmp_path / "instances.glb"
    path.write_bytes(scene.export(file_type="glb"))
    vertices, faces = read_mesh(path)
    loaded = trimesh.load_scene(path, process=False)
    dumped = [m for m in loaded.dump() if isinstance(m, trimesh.Trimesh)]
    expected_v = np.concatenate([m.vertices for m in dumped])
    offsets = np.cumsum([0] + [len(m.vertices) for m in dumped[:-1]])
    expected_f = np.concatenate([m.faces + k for m, k in zip(dumped, offsets, strict=True)])
    np.testing.assert_allclose(vertices, expected_v, atol=1e-12)
    np.testing.assert_array_equal(faces, expected_f)
    # The mirrored copy's normals still point outwards: winding reversed, not inside out.
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    assert mesh.volume > 0


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


def test_max_faces_checked_before_loading_absurd_header(tmp_path: Path) -> None:
    data = (ASSETS / "spot.ply").read_bytes().replace(b"face 5856", b"face 4000000000", 1)
    path = tmp_path / "absurd.ply"
    path.write_bytes(data)
    with pytest.raises(MeshError, match=r"needs at least 4000070320 bytes .* has 146448"):
        read_mesh(path, max_faces=10**12)  # the size of the file gives it away


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "10"])
def test_max_faces_must_be_positive_int(bad: object) -> None:
    with pytest.raises((TypeError, ValueError)):
        read_mesh(ASSETS / "spot.ply", max_faces=bad)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------


def _awkward_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Floats across the whole float64 range, signed zeros and an unreferenced vertex."""
    rng = np.random.default_rng(20240611)
    vertices = rng.standard_normal((300, 3)) * 10.0 ** rng.integers(-300, 300, (300, 3))
    vertices[0] = [5e-324, -0.0, 1.7976931348623157e308]
    vertices[1] = [0.1, 1 / 3, -2.0 / 7]
    faces = rng.integers(0, 299, (400, 3))  # vertex 299 unreferenced
    return vertices, faces


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
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


def test_round_trip_stl_float32(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = spot
    path = tmp_path / "out.stl"
    write_mesh(path, vertices, faces)
    read_vertices, read_faces = read_mesh(path)
    assert len(read_faces) == len(faces)

    np.testing.assert_array_equal(
        triangle_rows(read_vertices, read_faces, np.float32),
        triangle_rows(vertices, faces, np.float32),
    )


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".stl", ".PLY"])
def test_output_is_deterministic(
    suffix: str, tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]
) -> None:
    vertices, faces = spot
    write_mesh(tmp_path / f"a{suffix}", vertices, faces)
    write_mesh(tmp_path / f"b{suffix}", vertices.copy(), faces.copy())
    first = (tmp_path / f"a{suffix}").read_bytes()
    assert first == (tmp_path / f"b{suffix}").read_bytes()
    assert len(first) > 50_000


def test_write_does_not_modify_inputs(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    vertices, faces = (a.copy() for a in spot)
    vertices.flags.writeable = False
    faces.flags.writeable = False
    write_mesh(tmp_path / "x.obj", vertices, faces)
    assert np.array_equal(vertices, spot[0]) and np.array_equal(faces, spot[1])


def test_unknown_output_suffix(tmp_path: Path, spot: tuple[np.ndarray, np.ndarray]) -> None:
    assert WRITE_SUFFIXES == (".obj", ".ply", ".stl")
    check_output_suffix(tmp_path / "fine.STL")
    for name in ("mesh.glb", "mesh.off", "mesh"):
        with pytest.raises(MeshError, match=r"valid output suffixes are \.obj, \.ply, \.stl"):
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
        monkeypatch.setitem(mio._WRITERS, ".ply", _crash)
        expected: type[Exception] = RuntimeError  # a bug, not a bad file: propagates unchanged
    else:
        monkeypatch.setattr(mio.os, step, _fail)
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
    monkeypatch.setattr(mio.os, "replace", _fail)
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
