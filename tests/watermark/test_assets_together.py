"""Tests for :mod:`meshwm.watermark.assets`: a marked mesh saved as several objects is read
as one (separated by material or loose parts, an exporter's object per material).

Each file is written as a studio tool writes it: an OBJ whose objects have vertex records of
their own (the vertices along a border between parts written once per part), read back with
:func:`meshwm.mesh.asset.read_asset`.
"""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.attacks.seams import material_patches
from meshwm.mesh.asset import read_asset
from meshwm.watermark import Decoder, embed
from meshwm.watermark.assets import MIN_VERTICES_PER_BIT, extract_asset, verify_asset

KEY = "separated-key"
IDENT = bytes.fromhex("5ca1ab1e0ddba11f")
OTHER = bytes.fromhex("0123456789abcdef")


@pytest.fixture(scope="module")
def marked(spot_mesh):
    v, f = spot_mesh
    return embed(v, f, key=KEY, ident=IDENT).vertices, f


def write_objects(path, meshes) -> None:
    """An OBJ of one object per ``(name, vertices, faces, region)`` part: each part's own
    vertex records, full precision."""
    lines, base = [], 1
    for name, v, f, part in meshes:
        for p in np.unique(part):
            faces = f[part == p]
            used = np.unique(faces)
            where = np.empty(len(v), dtype=np.int64)
            where[used] = np.arange(len(used)) + base
            lines.append(f"o {name}{p}")
            lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in v[used].tolist()]
            lines += [f"f {a} {b} {c}" for a, b, c in where[faces].tolist()]
            base += len(used)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("seed", range(8))
def test_a_mesh_separated_into_objects_reads_as_one(marked, seed, tmp_path):
    """Eight random separations of marked spot into 6-8 patches: each part is too small to
    be read alone; read together they carry the id, in every row."""
    v, f = marked
    count = 6 + seed % 3
    path = tmp_path / "separated.obj"
    write_objects(path, [("part", v, f, material_patches(f, count=count, seed=seed))])
    asset = read_asset(path)
    assert len(asset.meshes) == count
    assert all(m.n_vertices < MIN_VERTICES_PER_BIT * 256 for m in asset.meshes)
    rows = verify_asset(asset, key=KEY, ident=IDENT)
    names = [m.name for m in asset.meshes]
    assert all(row["detected"] and row["id"] == IDENT.hex() for row in rows)
    total = sum(m.n_vertices for m in asset.meshes)
    assert all(row["together"] == {"meshes": names, "vertices": total} for row in rows)
    assert [row["name"] for row in rows] == names
    assert "reason" not in rows[0]
    found = extract_asset(asset, key=KEY)
    assert [row["kind"] for row in found] == ["id"] * count
    assert {row["id"] for row in found} == {IDENT.hex()}


def test_a_wrong_key_reads_the_parts_together_and_finds_nothing(marked, tmp_path):
    v, f = marked
    path = tmp_path / "separated.obj"
    write_objects(path, [("part", v, f, material_patches(f, count=6, seed=7))])
    rows = verify_asset(read_asset(path), key="another key", any_id=True)
    assert not any(row["detected"] for row in rows)
    assert not any("together" in row for row in rows)


def test_only_the_meshes_not_read_alone_are_read_together(marked, spot_mesh, tmp_path):
    """A prop marked with its own id reads alone and is left out; the two halves of another
    copy (moved aside) read together with their id."""
    v, f = marked
    other = embed(*spot_mesh, key=KEY, ident=OTHER).vertices + np.array([3.0, 0.0, 0.0])
    path = tmp_path / "kit.obj"
    halves = material_patches(f, count=2, seed=11)
    write_objects(
        path, [("crate", v, f, np.zeros(len(f), dtype=np.int64)), ("half", other, f, halves)]
    )
    asset = read_asset(path)
    rows = verify_asset(asset, key=KEY, any_id=True)
    assert [row["id"] for row in rows] == [IDENT.hex(), OTHER.hex(), OTHER.hex()]
    assert all(row["detected"] for row in rows)
    assert "together" not in rows[0]
    assert rows[1]["together"]["meshes"] == rows[2]["together"]["meshes"] == ["half0", "half1"]


def _setting():
    from meshwm.watermark.assets import _Setting

    return _Setting(None, 10**7, lambda _: None, 256)


def test_which_meshes_are_read_together(spot_mesh, tmp_path):
    """Parts sharing border positions are; two big meshes apart (a kit's props, each read
    alone) are not; a part too small to be read alone always joins."""
    from meshwm.watermark.assets import _together

    v, f = spot_mesh
    whole = np.zeros(len(f), dtype=np.int64)
    aside = np.array([3.0, 0.0, 0.0])
    tetra = np.eye(4, 3) + aside, np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    cases = {
        "halves": ([("half", v, f, material_patches(f, count=2, seed=11))], [0, 1]),
        "apart": ([("a", v, f, whole), ("b", v + aside, f, whole)], None),
        "small": ([("a", v, f, whole), ("s", *tetra, whole[:4])], [0, 1]),
    }
    for name, (meshes, members) in cases.items():
        path = tmp_path / f"{name}.obj"
        write_objects(path, meshes)
        asset = read_asset(path)
        joined = _together(asset, [False] * len(asset.meshes), _setting())
        assert (joined and joined[0]) == members, name
        if members:
            assert isinstance(joined[1], Decoder)
        # Nothing is read together once a mesh has been found.
        assert _together(asset, [True] + [False] * (len(asset.meshes) - 1), _setting()) is None
