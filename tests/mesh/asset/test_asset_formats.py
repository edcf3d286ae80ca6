"""The asset document (:mod:`meshwm.mesh.asset`): every byte but the moved positions is kept.

Each test writes a small file by hand (or with trimesh), reads it as a document, moves every
vertex by a known amount, writes it back and checks: the positions read back are the moved
ones (to the format's precision), and everything else (other records, properties, headers,
JSON, buffers) is the input's, byte for byte.  No marking here: these run in milliseconds.
"""

from __future__ import annotations

import base64
import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh
from _malformed import MUST_FAIL_ON_READ_IDS, MalformedCase, make_malformed_cases

from meshwm.errors import MeshError
from meshwm.mesh.asset import asset_bytes, read_asset, write_asset

SHIFT = np.array([0.001, -0.002, 0.0005])


def moved(asset):
    """The document with every mesh's vertices shifted by SHIFT."""
    return asset.with_positions([asset.vertices(k) + SHIFT for k in range(len(asset.meshes))])


def round_trip(path: Path):
    """(document, marked bytes, document read back from them)."""
    asset = read_asset(path)
    data = asset_bytes(moved(asset))
    out = path.with_name("out" + path.suffix)
    out.write_bytes(data)
    return asset, data, read_asset(out)


def assert_moved(before, after, atol):
    for k in range(len(before.meshes)):
        np.testing.assert_allclose(after.vertices(k), before.vertices(k) + SHIFT, atol=atol, rtol=0)


# --- OBJ ------------------------------------------------------------------------------------

OBJ = b"""# made by a studio tool\r
mtllib kit.mtl\r
o crate\r
v 0.000000 0.000000 0.000000\r
v 1.000000 0.000000 0.000000 0.5 0.25 0.125\r
v 1.000000 1.000000 0.000000\r
  v\t0.000000 1.000000 0.000000\r
vt 0.0 0.0\r
vt 1.0 0.0\r
vt 1.0 1.0\r
vn 0 0 1\r
g lid\r
usemtl wood\r
s 1\r
f 1/1/1 2/2/1 3/3/1 4/3/1\r
o bolt\r
v 5.000000 0.000000 0.000000\r
v 6.000000 0.000000 0.000000\r
v 5.000000 1.000000 0.000000\r
usemtl steel\r
f -3 -2 -1\r
l 1 2\r
"""


def test_obj_keeps_every_line_but_the_moved_vertices(tmp_path):
    path = tmp_path / "kit.obj"
    path.write_bytes(OBJ)
    asset, data, again = round_trip(path)
    assert [(m.name, len(m.faces), m.polygons) for m in asset.meshes] == [
        ("crate", 2, 1),
        ("bolt", 1, 1),
    ]
    s = asset.summary
    assert (s.vertices, s.faces, s.polygons, s.uvs, s.normals, s.colors, s.materials) == (
        7, 2, 1, 3, 1, 1, 2,
    )  # fmt: skip
    assert again.summary == asset.summary
    assert_moved(asset, again, atol=1e-6)
    old, new = OBJ.split(b"\n"), data.split(b"\n")
    assert len(old) == len(new)
    for a, b in zip(old, new, strict=True):
        if a.strip().startswith(b"v") and a.split()[0] == b"v":
            assert b.endswith(b"\r") and b.startswith(a[: len(a) - len(a.lstrip())])
        else:
            assert a == b
    # The fourth vertex keeps its indentation and tab; the second its colours.
    assert new[6].startswith(b"  v\t-0.001000 ") or new[6].startswith(b"  v\t0.001000 ")
    assert new[4].endswith(b" 0.5 0.25 0.125\r")
    # Moving the positions back gives the file again, byte for byte.
    restored = again.with_positions([asset.vertices(k) for k in range(len(asset.meshes))])
    assert asset_bytes(restored) == OBJ


def test_obj_objects_that_share_a_vertex_are_one_mesh(tmp_path):
    path = tmp_path / "shared.obj"
    text = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\no b\nf 2 4 3\n"
    path.write_text(text)
    asset = read_asset(path)
    assert [m.name for m in asset.meshes] == ["a+b"]
    assert asset.meshes[0].n_vertices == 4


def test_obj_groups_are_meshes_when_there_are_no_objects(tmp_path):
    path = tmp_path / "groups.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 0 0\nv 6 0 0\nv 5 1 0\n")
    with open(path, "a") as f:
        f.write("g left\nf 1 2 3\ng right\nf 4 5 6\n")
    assert [m.name for m in read_asset(path).meshes] == ["left", "right"]


def test_obj_coordinates_keep_the_files_decimals_and_resolve_the_mark(tmp_path):
    path = tmp_path / "coarse.obj"
    path.write_text("v 0.5 0 0\nv 10 0 0\nv 0 10 0\nf 1 2 3\n")
    asset = read_asset(path)
    data = asset_bytes(moved(asset))
    # 1e-6 of a 14-unit diagonal needs 5 decimals, more than the file's one.
    assert data.split(b"\n")[0] == b"v 0.50100 -0.00200 0.00050"


def test_an_old_tool_signature_is_dropped(tmp_path):
    path = tmp_path / "old.obj"
    path.write_text("# written by meshwm\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert b"meshwm" not in asset_bytes(moved(read_asset(path)))


# --- PLY ------------------------------------------------------------------------------------


def _ply(path: Path, order: str, xyz: str, quads: bool = False) -> bytes:
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
    vertex = np.zeros(
        5,
        [("x", order + xyz), ("y", order + xyz), ("z", order + xyz), ("red", "u1"),
         ("green", "u1"), ("blue", "u1"), ("quality", order + "f4")],
    )  # fmt: skip
    for c, n in enumerate("xyz"):
        vertex[n] = v[:, c]
    vertex["red"], vertex["green"], vertex["blue"] = 10, 20, 30
    vertex["quality"] = np.arange(5)
    kind = {"f4": "float", "f8": "double"}[xyz]
    header = [
        "ply", f"format binary_{'little' if order == '<' else 'big'}_endian 1.0",
        "comment scanned", "element vertex 5",
        *[f"property {kind} {n}" for n in "xyz"],
        "property uchar red", "property uchar green", "property uchar blue",
        "property float quality",
    ]  # fmt: skip
    if quads:  # a quad and two triangles: lists of different lengths
        faces = b"".join(
            struct.pack(f"{order}B{n}iB", n, *idx, flag)
            for n, idx, flag in [(4, (0, 1, 2, 3), 7), (3, (0, 1, 4), 8), (3, (1, 2, 4), 9)]
        )
        n_faces = 3
    else:
        faces = b"".join(
            struct.pack(f"{order}B3iB", 3, *idx, k)
            for k, idx in enumerate([(0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)])
        )
        n_faces = 4
    header += [f"element face {n_faces}", "property list uchar int vertex_indices"]
    header += ["property uchar flags", "end_header", ""]
    data = "\n".join(header).encode() + vertex.tobytes() + faces
    path.write_bytes(data)
    return data


@pytest.mark.parametrize("order", ["<", ">"], ids=["little", "big"])
@pytest.mark.parametrize("xyz", ["f4", "f8"], ids=["float32", "float64"])
@pytest.mark.parametrize("quads", [False, True], ids=["triangles", "mixed"])
def test_ply_keeps_header_properties_and_dtype(order, xyz, quads, tmp_path):
    path = tmp_path / "scan.ply"
    original = _ply(path, order, xyz, quads)
    asset, data, again = round_trip(path)
    assert len(data) == len(original)
    start = original.index(b"end_header\n") + len(b"end_header\n")
    assert data[:start] == original[:start]
    row = np.dtype([(n, order + xyz) for n in "xyz"] + [("rgb", "3u1"), ("q", order + "f4")])
    before = np.frombuffer(original, row, 5, start)
    after = np.frombuffer(data, row, 5, start)
    assert np.array_equal(before[["rgb", "q"]], after[["rgb", "q"]])
    assert data[start + 5 * row.itemsize :] == original[start + 5 * row.itemsize :]
    expected = np.stack([before[n].astype(float) for n in "xyz"], 1) + SHIFT
    got = np.stack([after[n] for n in "xyz"], 1)  # stored in the file's own type and order
    np.testing.assert_array_equal(got, expected.astype(xyz))
    assert again.summary == asset.summary
    assert asset.summary.colors == 5 and asset.summary.polygons == (1 if quads else 0)
    assert asset.summary.dtype.startswith({"f4": "float32", "f8": "float64"}[xyz])


def test_ascii_ply_rewrites_only_the_coordinate_tokens(tmp_path):
    mesh = trimesh.creation.box()
    mesh.visual.vertex_colors = [200, 100, 50, 255]
    path = tmp_path / "box.ply"
    original = mesh.export(file_type="ply", encoding="ascii")
    path.write_bytes(original)
    asset, data, again = round_trip(path)
    lines_in, lines_out = original.split(b"\n"), data.split(b"\n")
    assert len(lines_in) == len(lines_out)
    body = [k for k, (a, b) in enumerate(zip(lines_in, lines_out, strict=True)) if a != b]
    assert len(body) == 8  # the eight vertex rows, nothing else
    for k in body:
        assert lines_out[k].split()[3:] == lines_in[k].split()[3:]  # the colours
    assert_moved(asset, again, atol=1e-6)


# --- STL ------------------------------------------------------------------------------------


def test_binary_stl_keeps_header_and_attributes_and_stays_welded(tmp_path):
    mesh = trimesh.creation.icosphere(1)
    data = bytearray(mesh.export(file_type="stl"))
    data[:80] = b"studio header".ljust(80)
    records = np.frombuffer(data, [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")], -1, 84)
    records["a"] = np.arange(len(records))  # attribute words (colour in some tools)
    path = tmp_path / "ball.stl"
    path.write_bytes(bytes(data))
    asset, out, again = round_trip(path)
    assert asset.meshes[0].n_vertices == len(mesh.vertices)  # corners welded by position
    assert out[:84] == bytes(data[:84])
    after = np.frombuffer(out, records.dtype, -1, 84)
    assert np.array_equal(after["a"], records["a"])
    v = after["v"].astype(float)
    normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    np.testing.assert_allclose(after["n"], normal, atol=1e-6)
    assert again.meshes[0].n_vertices == len(mesh.vertices)  # no corner moved apart
    assert_moved(asset, again, atol=1e-6)


def test_ascii_stl_solids_are_meshes(tmp_path):
    one = trimesh.creation.box().export(file_type="stl_ascii").replace("solid", "solid lid", 1)
    two = trimesh.creation.icosphere(0).export(file_type="stl_ascii")
    path = tmp_path / "two.stl"
    path.write_text(one.replace("endsolid", "endsolid lid") + two)
    asset, data, again = round_trip(path)
    assert [m.name for m in asset.meshes] == ["lid", "mesh"]
    assert_moved(asset, again, atol=1e-5)
    assert data.count(b"facet normal") == path.read_bytes().count(b"facet normal")


# --- OFF ------------------------------------------------------------------------------------


def test_off_keeps_colours_and_polygons(tmp_path):
    path = tmp_path / "quad.off"
    text = (
        "COFF\n# a comment\n5 2 0\n0.000 0.000 0.000 255 0 0 255\n1.000 0.000 0.000 0 255 0 255\n"
        "1.000 1.000 0.000 0 0 255 255\n0.000 1.000 0.000 9 9 9 255\n0.500 0.500 1.000 1 2 3 4\n"
        "4 0 1 2 3 10 20 30\n3 0 1 4\n"
    )
    path.write_text(text)
    asset, data, again = round_trip(path)
    assert asset.summary.polygons == 1 and asset.summary.colors == 5
    lines_in, lines_out = text.encode().split(b"\n"), data.split(b"\n")
    for a, b in zip(lines_in, lines_out, strict=True):
        if len(a.split()) == 7:
            assert b.split()[3:] == a.split()[3:]
        else:
            assert a == b
    assert_moved(asset, again, atol=1e-6)


# --- glTF -----------------------------------------------------------------------------------


def _glb_kit() -> bytes:
    scene = trimesh.Scene()
    box = trimesh.creation.box()
    box.visual.material = trimesh.visual.material.PBRMaterial(name="steel", metallicFactor=1.0)
    ball = trimesh.creation.icosphere(1)
    scene.add_geometry(box, node_name="Crate", transform=trimesh.transformations.scale_matrix(2))
    scene.add_geometry(
        ball, node_name="Ball", transform=trimesh.transformations.translation_matrix([3, 0, 0])
    )
    return scene.export(file_type="glb")


def _split(data: bytes) -> tuple[dict, bytes]:
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20 : 20 + length]), data[20 + length + 8 :]


def test_glb_keeps_the_scene_and_changes_only_positions_and_their_bounds(tmp_path):
    path = tmp_path / "kit.glb"
    original = _glb_kit()
    path.write_bytes(original)
    asset, data, again = round_trip(path)
    assert sorted(m.name for m in asset.meshes) == ["Ball", "Crate"]
    gltf_in, bin_in = _split(original)
    gltf_out, bin_out = _split(data)
    positions = set()
    for k, acc in enumerate(gltf_in["accessors"]):
        if any(
            p["attributes"]["POSITION"] == k for m in gltf_in["meshes"] for p in m["primitives"]
        ):
            positions.add(k)
            view = gltf_in["bufferViews"][acc["bufferView"]]
            stored = np.frombuffer(bin_out, "<f4", 3 * acc["count"], view.get("byteOffset", 0))
            assert gltf_out["accessors"][k]["min"] == stored.reshape(-1, 3).min(0).tolist()
    for k in positions:
        for name in ("min", "max"):
            del gltf_in["accessors"][k][name], gltf_out["accessors"][k][name]
    assert gltf_in == gltf_out  # nodes, names, transforms, materials: all the same
    assert len(bin_in) == len(bin_out)
    assert_moved(asset, again, atol=1e-6)


def test_gltf_with_an_external_buffer_embeds_the_changed_one(tmp_path):
    glb = _glb_kit()
    gltf, binary = _split(glb)
    gltf["buffers"] = [{"byteLength": gltf["buffers"][0]["byteLength"], "uri": "kit data.bin"}]
    (tmp_path / "kit data.bin").write_bytes(binary)
    path = tmp_path / "kit.gltf"
    path.write_text(json.dumps(gltf, indent=2))
    asset = read_asset(path)
    assert asset.sidecars == ("kit data.bin",)
    out = tmp_path / "sub"
    out.mkdir()
    written = write_asset(out / "kit.gltf", moved(asset))
    uri = json.loads((out / "kit.gltf").read_text())["buffers"][0]["uri"]
    assert uri.startswith("data:application/octet-stream;base64,")
    assert len(base64.b64decode(uri.split(",", 1)[1])) == len(binary)
    assert (tmp_path / "kit data.bin").read_bytes() == binary  # the input's .bin untouched
    assert_moved(asset, written, atol=1e-6)


def test_compressed_positions_are_a_reason_not_a_crash(tmp_path):
    gltf, binary = _split(_glb_kit())
    gltf["accessors"][gltf["meshes"][0]["primitives"][0]["attributes"]["POSITION"]][
        "componentType"
    ] = 5123  # quantised (KHR_mesh_quantization)
    path = tmp_path / "q.gltf"
    gltf["buffers"][0]["uri"] = (
        "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
    )
    path.write_text(json.dumps(gltf))
    reasons = {m.name: m.reason for m in read_asset(path).meshes}
    assert sorted(reasons.values(), key=str) == [
        None,
        "its positions are quantised (integers), not float32",
    ]


# --- writing --------------------------------------------------------------------------------


def test_conversion_to_glb_names_no_tool(tmp_path):
    path = tmp_path / "box.ply"
    path.write_bytes(trimesh.creation.box().export(file_type="ply"))
    asset = read_asset(path)
    written = write_asset(tmp_path / "box.glb", moved(asset))
    data = (tmp_path / "box.glb").read_bytes()
    assert b"trimesh" not in data and b"meshwm" not in data
    assert_moved(asset, written, atol=1e-6)


def test_a_conversion_says_what_it_lost(tmp_path):
    path = tmp_path / "kit.obj"
    path.write_bytes(OBJ)
    asset = read_asset(path)
    written = write_asset(tmp_path / "kit.ply", moved(asset))
    changes = written.summary.changes_from(asset.summary)
    assert any(c.startswith("uvs 3 -> ") for c in changes)


def test_write_refuses_the_input_and_unknown_suffixes(tmp_path):
    path = tmp_path / "kit.obj"
    path.write_bytes(OBJ)
    asset = moved(read_asset(path))
    with pytest.raises(MeshError, match="would overwrite the input; use --force"):
        write_asset(path, asset, overwrite_input=path)
    with pytest.raises(MeshError, match=r"valid output suffixes are \.glb, \.gltf, \.obj"):
        write_asset(tmp_path / "kit.fbx", asset)
    assert path.read_bytes() == OBJ and sorted(p.name for p in tmp_path.iterdir()) == ["kit.obj"]
    write_asset(path, asset, overwrite_input=path, force=True)
    assert path.read_bytes() != OBJ


@pytest.mark.parametrize(
    "name, data, message",
    [
        ("nan.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "NaN"),
        ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "does not exist"),
        ("short.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n", "end_header"),
        ("noface.off", b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", "no faces"),
        ("junk.glb", b"glTF\x02\x00\x00\x00\x10\x00\x00\x00junk", "GLB"),
        ("empty.stl", b"", "empty"),
    ],
)
def test_bad_files_are_one_line_errors(name, data, message, tmp_path):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(MeshError, match=message) as info:
        read_asset(path)
    assert "\n" not in str(info.value) and str(info.value).startswith(str(path))


def test_a_conversion_keeps_a_mesh_split_by_material_whole(tmp_path):
    """trimesh splits an OBJ by usemtl; each mesh carries its mark whole, so it is joined."""
    box = trimesh.creation.box()
    lines = ["mtllib two.mtl", "o box"] + [f"v {x} {y} {z}" for x, y, z in box.vertices]
    for k, face in enumerate(box.faces + 1):
        if k in (0, 6):
            lines.append(f"usemtl {'red' if k == 0 else 'blue'}")
        lines.append("f " + " ".join(map(str, face)))
    (tmp_path / "two.mtl").write_text("newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
    path = tmp_path / "box.obj"
    path.write_text("\n".join(lines) + "\n")
    asset = read_asset(path)
    written = write_asset(tmp_path / "box.glb", moved(asset))
    assert [m.name for m in written.meshes] == ["box"]
    assert written.meshes[0].n_vertices == 8
    expected = np.sort((asset.vertices(0) + SHIFT).view("f8,f8,f8").ravel())  # any order
    got = np.sort(written.vertices(0).view("f8,f8,f8").ravel())
    np.testing.assert_allclose(got.view("f8").reshape(-1, 3), expected.view("f8").reshape(-1, 3),
                               atol=1e-6, rtol=0)  # fmt: skip


@pytest.fixture(scope="module")
def malformed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, MalformedCase]:
    """The malformed files of ``tests/_malformed.py`` (the reader of bare meshes refuses them)."""
    cases = make_malformed_cases(tmp_path_factory.mktemp("malformed"))
    return {case.case_id: case for case in cases}


@pytest.mark.parametrize("case_id", MUST_FAIL_ON_READ_IDS)
def test_malformed_files_are_refused_as_documents_too(case_id, malformed, capfd):
    path = malformed[case_id].path
    with pytest.raises(MeshError) as info:
        read_asset(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    assert capfd.readouterr() == ("", "")
