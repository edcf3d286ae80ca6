"""The column-wise face cross products are np.cross's bits (meshwm._vector)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from meshwm._vector import face_cross, row_norm


@pytest.mark.parametrize("seed", range(5))
def test_face_cross_is_np_cross_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scale = 10.0 ** rng.uniform(-6, 6)
    v = (rng.standard_normal((500, 3)) * scale + rng.uniform(-1e3, 1e3, 3)).astype(np.float64)
    f = rng.integers(0, len(v), (2000, 3))
    f[:20, 1] = f[:20, 0]  # degenerate faces: exact zeros
    want = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    got = face_cross(v, f)
    assert np.array_equal(np.stack(got, axis=1), want)
    assert np.array_equal(row_norm(got), np.linalg.norm(want, axis=1))
    assert not np.any(np.stack(got, axis=1)[:20])


def test_face_cross_on_a_mesh_with_int32_faces() -> None:
    mesh = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int32)
    want = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.array_equal(np.stack(face_cross(v, f), axis=1), want)


@pytest.mark.parametrize("chunk", [1 << 16, 7, 1])
def test_face_area_is_half_the_cross_norm_bit_for_bit(monkeypatch, chunk: int) -> None:
    import meshwm._vector as vector

    monkeypatch.setattr(vector, "_CHUNK", chunk)
    rng = np.random.default_rng(chunk)
    v = rng.standard_normal((300, 3)) * 1e3
    f = rng.integers(0, len(v), (1000, 3))
    want = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    assert np.array_equal(vector.face_area(v, f), want)
    assert vector.face_area(v, f[:0]).shape == (0,)
