"""The studio's asset, whole: the must-show table of issue 15.

Builds, in a temporary folder, the files a studio sends out: a textured OBJ (``.mtl`` and a PNG
texture, ``vt``/``vn``, ``o``/``g``/``usemtl``), a quad OBJ, a three-mesh GLB (names,
transforms, materials, a texture, UVs), a PLY with vertex colours, normals and extra vertex
and face properties, a float32 PLY and a binary STL; from the bundled spot and simple
generated meshes (trimesh and NumPy).  Each goes through ``meshwm embed`` (in-process, the key
from ``--key-file``, a text id; the GLB with one id per mesh), and the table gives, per file,
what went in and what came out (vertices, faces, polygons, UVs, normals, colours, materials,
meshes, dtype, size), whether every byte but the positions is the input's, and the id read
back blind per mesh (``meshwm verify --any-id``).  It also checks that no output holds the
bytes ``meshwm`` or the key.

    python scripts/check_assets.py [--keep DIR]

``--keep DIR`` leaves the inputs and outputs there (the render pictures of docs/assets.md
were drawn from them).
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import io
import json
import struct
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import meshwm
from meshwm.apps.cli import main
from meshwm.mesh.asset import read_asset
from meshwm.message.payload import format_id, parse_id
from meshwm.watermark.assets import verify_asset

KEY = "studio-secret-2026"
#: Which id each file gets (per mesh for the GLB).
IDS = {
    "spot_textured.obj": "VENDOR_A",
    "panel_quads.obj": "VENDOR_B",
    "kit.glb": None,
    "spot_colors.ply": "0xC0FFEE42",
    "spot_f32.ply": "build-42",
    "spot.stl": "VENDOR_C",
    "rock_colors.off": "rock-01",
    "rock.gltf": "rock-02",
}
KIT_IDS = {"Spot": "kit-spot", "Rock": "kit-rock", "Crate": "kit-box"}


def bumpy_sphere(subdivisions: int = 4, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere with smooth random bumps and stretched axes (no symmetry to tie the cut)."""
    sphere = trimesh.creation.icosphere(subdivisions)
    v = np.array(sphere.vertices)
    k = np.random.default_rng(seed).normal(size=(6, 3))
    v *= (1 + 0.15 * np.sin(v @ k.T).sum(axis=1))[:, None]
    return v * [1.3, 0.8, 1.0], np.array(sphere.faces)


def quad_box(k: int = 20, seed: int = 3) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """A closed quad mesh: a cube's six sides in k×k quads, pushed onto a bumpy blob.

    Returns the vertices, the (q, 4) quads and each quad's side (for ``g`` groups).
    """
    grid = np.linspace(-1, 1, k + 1)
    points, quads, sides = [], [], []
    index: dict[tuple[float, float, float], int] = {}
    for side, (axis, sign) in enumerate((a, s) for a in range(3) for s in (-1, 1)):
        others = [c for c in range(3) if c != axis]
        ids = np.empty((k + 1, k + 1), dtype=int)
        for i, a in enumerate(grid):
            for j, b in enumerate(grid):
                p = [0.0, 0.0, 0.0]
                p[axis], p[others[0]], p[others[1]] = sign, a, b
                ids[i, j] = index.setdefault((p[0], p[1], p[2]), len(index))
        for i in range(k):
            for j in range(k):
                q = [ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]]
                quads.append(q if (sign > 0) == (axis != 1) else q[::-1])
                sides.append(side)
    points = np.array(list(index), dtype=float)
    v = points / np.linalg.norm(points, axis=1, keepdims=True)
    r = np.random.default_rng(seed).normal(size=(5, 3))
    v *= (1 + 0.12 * np.sin(1.5 * v @ r.T).sum(axis=1))[:, None]
    v *= [1.0, 0.7, 1.4]
    faces = np.array(quads)
    # Orient every quad outwards (its normal along its centre).
    centre = v[faces].mean(axis=1)
    normal = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    flip = (normal * centre).sum(axis=1) < 0
    faces[flip] = faces[flip][:, ::-1]
    return v, faces, sides


def checker_png(size: int = 256) -> bytes:
    """A UV checker: 8×8 squares, the hue running along u, the brightness along v."""
    u, v = np.meshgrid(np.linspace(0, 1, size), np.linspace(0, 1, size))
    checker = ((np.floor(u * 8) + np.floor(v * 8)) % 2).astype(float)
    rgb = np.stack([0.5 + 0.5 * np.cos(2 * np.pi * (u + t)) for t in (0, 1 / 3, 2 / 3)], axis=-1)
    rgb = rgb * (0.55 + 0.45 * checker)[..., None] * (0.6 + 0.4 * v)[..., None]
    buffer = io.BytesIO()
    Image.fromarray((255 * rgb).astype(np.uint8)).save(buffer, format="PNG")
    return buffer.getvalue()


def spherical_uv(vertices: np.ndarray) -> np.ndarray:
    """Per-vertex UVs from the direction to the centroid."""
    d = vertices - vertices.mean(axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    u = np.arctan2(d[:, 2], d[:, 0]) / (2 * np.pi) + 0.5
    return np.stack([u, np.arccos(d[:, 1]) / np.pi], axis=1)


def spot() -> trimesh.Trimesh:
    return trimesh.load(meshwm.data.path("spot"), process=False)


def write_textured_obj(folder: Path) -> Path:
    """spot with per-corner UVs (a seam: more vt than v), per-vertex normals, a material."""
    mesh = spot()
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    uv = spherical_uv(v)[f]  # (m, 3, 2) per corner
    wrap = uv[:, :, 0].max(axis=1) - uv[:, :, 0].min(axis=1) > 0.5
    uv[wrap, :, 0] = np.where(uv[wrap, :, 0] < 0.5, uv[wrap, :, 0] + 1.0, uv[wrap, :, 0])
    texcoords, vt = np.unique(np.round(uv.reshape(-1, 2), 6), axis=0, return_inverse=True)
    vt = vt.reshape(-1, 3) + 1
    normals = np.asarray(mesh.vertex_normals)
    lines = ["# Blender 4.1.1", "# www.blender.org", "mtllib spot.mtl", "o spot"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
    lines += [f"vt {a:.6f} {b:.6f}" for a, b in texcoords]
    lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in normals]
    lines += ["s 1", "g body", "usemtl spot_skin"]
    half = len(f) // 2
    for k, (face, corner) in enumerate(zip(f + 1, vt, strict=True)):
        if k == half:
            lines += ["g head", "usemtl spot_spots"]
        lines.append("f " + " ".join(f"{a}/{b}/{a}" for a, b in zip(face, corner, strict=True)))
    (folder / "spot.mtl").write_text(
        "newmtl spot_skin\nKa 1 1 1\nKd 1 1 1\nmap_Kd spot_texture.png\n\n"
        "newmtl spot_spots\nKa 1 1 1\nKd 0.9 0.9 0.9\nmap_Kd spot_texture.png\n"
    )
    (folder / "spot_texture.png").write_bytes(checker_png())
    path = folder / "spot_textured.obj"
    path.write_text("\n".join(lines) + "\n")
    return path


def write_quad_obj(folder: Path) -> Path:
    v, quads, sides = quad_box()
    lines = ["# exported by a studio tool", "o panel_box"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
    for side in range(6):
        lines.append(f"g side_{side}")
        lines += [
            "f " + " ".join(str(i + 1) for i in q)
            for q, s in zip(quads, sides, strict=True)
            if s == side
        ]
    path = folder / "panel_quads.obj"
    path.write_text("\n".join(lines) + "\n")
    return path


def write_kit_glb(folder: Path) -> Path:
    """Three props as three named nodes with transforms and materials; spot is textured."""
    scene = trimesh.Scene()
    cow = spot()
    material = trimesh.visual.material.PBRMaterial(
        name="spot_skin", baseColorTexture=Image.open(io.BytesIO(checker_png(128)))
    )
    cow.visual = trimesh.visual.TextureVisuals(uv=spherical_uv(cow.vertices), material=material)
    rock = trimesh.Trimesh(*bumpy_sphere(4, 1), process=False)
    rock.visual.material = trimesh.visual.material.PBRMaterial(
        name="rock_grey", baseColorFactor=[120, 110, 100, 255], roughnessFactor=0.9
    )
    crate = trimesh.Trimesh(*bumpy_sphere(4, 3), process=False)
    crate.visual.material = trimesh.visual.material.PBRMaterial(
        name="crate_wood", baseColorFactor=[160, 110, 60, 255], metallicFactor=0.0
    )
    turn = trimesh.transformations.rotation_matrix(0.6, [0, 1, 0])
    place = [
        ("Spot", cow, trimesh.transformations.translation_matrix([0, 0, 0])),
        ("Rock", rock, trimesh.transformations.translation_matrix([2.5, 0.2, 0]) @ turn),
        ("Crate", crate, trimesh.transformations.scale_and_translate(0.5, [-2.5, 0, 1])),
    ]
    for name, mesh, transform in place:
        scene.add_geometry(mesh, node_name=name, geom_name=f"{name}_mesh", transform=transform)
    data = scene.export(file_type="glb", include_normals=True)
    (length,) = struct.unpack_from("<I", data, 12)
    gltf = json.loads(data[20 : 20 + length])
    gltf["asset"] = {"version": "2.0", "generator": "Khronos glTF Blender I/O v4.1.63"}
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + length :]
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
    path = folder / "kit.glb"
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    return path


def _ply(path: Path, header: list[str], vertex: np.ndarray, face: np.ndarray) -> Path:
    text = "\n".join(["ply", "format binary_little_endian 1.0", *header, "end_header"]) + "\n"
    path.write_bytes(text.encode() + vertex.tobytes() + face.tobytes())
    return path


def write_plys(folder: Path) -> list[Path]:
    mesh = spot()
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    rich = np.zeros(
        len(v),
        [("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4"),
         ("red", "u1"), ("green", "u1"), ("blue", "u1"), ("alpha", "u1"), ("quality", "<f4")],
    )  # fmt: skip
    for c, name in enumerate("xyz"):
        rich[name] = v[:, c]
        rich["n" + name] = mesh.vertex_normals[:, c]
    colour = (255 * (v - v.min(0)) / np.ptp(v, axis=0)).astype(np.uint8)
    rich["red"], rich["green"], rich["blue"], rich["alpha"] = *colour.T, 255
    rich["quality"] = np.linalg.norm(v, axis=1)
    faces = np.zeros(len(f), [("n", "u1"), ("i", "<i4", (3,)), ("flags", "u1")])
    faces["n"], faces["i"], faces["flags"] = 3, f, np.arange(len(f)) % 7
    names = ["x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha", "quality"]
    types = ["double"] * 3 + ["float"] * 3 + ["uchar"] * 4 + ["float"]
    header = ["comment scanned at the studio", f"element vertex {len(v)}"]
    header += [f"property {t} {n}" for t, n in zip(types, names, strict=True)]
    header += [f"element face {len(f)}", "property list uchar int vertex_indices"]
    header += ["property uchar flags"]
    colors = _ply(folder / "spot_colors.ply", header, rich, faces)
    plain = np.zeros(len(v), [("x", "<f4"), ("y", "<f4"), ("z", "<f4")])
    for c, name in enumerate("xyz"):
        plain[name] = v[:, c]
    tri = np.zeros(len(f), [("n", "u1"), ("i", "<i4", (3,))])
    tri["n"], tri["i"] = 3, f
    header = [f"element vertex {len(v)}", "property float x", "property float y"]
    header += ["property float z", f"element face {len(f)}"]
    header += ["property list uchar int vertex_indices"]
    return [colors, _ply(folder / "spot_f32.ply", header, plain, tri)]


def write_stl(folder: Path) -> Path:
    data = bytearray(spot().export(file_type="stl"))
    data[:80] = b"studio export, units: m".ljust(80, b" ")
    path = folder / "spot.stl"
    path.write_bytes(bytes(data))
    return path


def write_off(folder: Path) -> Path:
    """A COFF file: a bumpy sphere with a colour per vertex."""
    v, f = bumpy_sphere(4, 5)
    colour = (255 * (v - v.min(0)) / np.ptp(v, axis=0)).astype(int)
    lines = ["COFF", "# scanned rock", f"{len(v)} {len(f)} 0"]
    lines += [
        f"{x:.6f} {y:.6f} {z:.6f} {r} {g} {b} 255"
        for (x, y, z), (r, g, b) in zip(v, colour, strict=True)
    ]
    lines += [f"3 {a} {b} {c}" for a, b, c in f]
    path = folder / "rock_colors.off"
    path.write_text("\n".join(lines) + "\n")
    return path


def write_gltf(folder: Path) -> Path:
    """A .gltf with its buffer in an external .bin file (a sidecar)."""
    mesh = trimesh.Trimesh(*bumpy_sphere(4, 7), process=False)
    data = mesh.export(file_type="glb", include_normals=True)
    (length,) = struct.unpack_from("<I", data, 12)
    gltf = json.loads(data[20 : 20 + length])
    gltf["asset"] = {"version": "2.0", "generator": "studio exporter 2.3"}
    binary = data[20 + length + 8 :]
    gltf["buffers"] = [{"byteLength": gltf["buffers"][0]["byteLength"], "uri": "rock.bin"}]
    (folder / "rock.bin").write_bytes(binary)
    path = folder / "rock.gltf"
    path.write_text(json.dumps(gltf, indent=2))
    return path


def build_inputs(folder: Path) -> list[Path]:
    """Every input file of the table, written into ``folder``."""
    return [
        write_textured_obj(folder),
        write_quad_obj(folder),
        write_kit_glb(folder),
        *write_plys(folder),
        write_stl(folder),
        write_off(folder),
        write_gltf(folder),
    ]


def _glb_parts(data: bytes) -> tuple[dict, bytes]:
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20 : 20 + length]), data[20 + length + 8 :]


def _same_but_positions(before: Any, after_path: Path) -> str:
    """Whether the output is the input but for the positions: move them back and compare.

    Text and PLY files must then be the input byte for byte; GLB/glTF the same JSON (the
    position bounds follow the positions) and the same buffers; STL the same header and
    attribute words (the normals of moved facets are recomputed).
    """
    from meshwm.mesh.asset import asset_bytes

    after = read_asset(after_path)
    restored = after.with_positions([before.vertices(k) for k in range(len(before.meshes))])
    again = asset_bytes(restored)
    if before.suffix == ".glb":
        same = _glb_parts(again) == _glb_parts(before.data)
    elif before.suffix == ".gltf":
        gltf = json.loads(again)
        buffer = base64.b64decode(gltf["buffers"][0]["uri"].split(",", 1)[1])
        same = _strip_buffers(gltf) == _strip_buffers(json.loads(before.data))
        same = same and buffer == before.state["buffers"][0]
    elif before.suffix == ".stl":
        record = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
        a, b = np.frombuffer(again, record, -1, 84), np.frombuffer(before.data, record, -1, 84)
        same = again[:84] == before.data[:84] and np.array_equal(a[["v", "a"]], b[["v", "a"]])
        return "header, attributes same; normals recomputed" if same else "CHANGED"
    else:
        same = again == before.data
    return "other bytes same" if same else "OTHER BYTES CHANGED"


def _strip_buffers(gltf: dict) -> dict:
    """The JSON without its buffer URIs (a changed external buffer is embedded)."""
    return {k: v for k, v in gltf.items() if k != "buffers"}


def _row(label: str, asset: Any, size: int) -> list[str]:
    """One line of the table; a .gltf's size counts the external buffers it refers to."""
    s = asset.summary
    if asset.suffix == ".gltf" and asset.path is not None:
        size += sum(
            (asset.path.parent / name).stat().st_size
            for name in asset.sidecars
            if (asset.path.parent / name).is_file()
        )
    return [
        label, str(s.vertices), str(s.faces), str(s.polygons), str(s.uvs), str(s.normals),
        str(s.colors), str(s.materials), str(s.meshes), s.dtype, f"{size / 1024:.1f} KB",
    ]  # fmt: skip


def run(folder: Path) -> int:
    (folder / "key.txt").write_text(KEY + "\n")
    out_dir = folder / "marked"
    out_dir.mkdir()
    header = ["file", "vertices", "faces", "polygons", "UVs", "normals", "colours",
              "materials", "meshes", "dtype", "size"]  # fmt: skip
    table: list[list[str]] = []
    reads: list[str] = []
    problems: list[str] = []
    for path in build_inputs(folder):
        started = time.perf_counter()
        out = out_dir / path.name
        argv = ["embed", str(path), "-o", str(out), "--key-file", str(folder / "key.txt")]
        argv.append("--json")
        if IDS[path.name] is None:
            for name, value in KIT_IDS.items():
                argv += ["--mesh-id", f"{name}={value}"]
        else:
            argv += ["--id", str(IDS[path.name])]
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            code = main(argv)
        if code != 0:
            problems.append(f"{path.name}: embed exit {code}: {stderr.getvalue().strip()}")
            continue
        before, after = read_asset(path), read_asset(out)
        table.append(_row(f"{path.name} in", before, path.stat().st_size))
        table.append(_row(f"{path.name} out", after, out.stat().st_size))
        kept = after.summary == before.summary
        bytes_kept = _same_but_positions(before, out)
        for name in before.sidecars:  # an OBJ's .mtl and texture, a .gltf's .bin: untouched
            if (folder / name).exists() and not (out_dir / name).exists():
                (out_dir / name).write_bytes((folder / name).read_bytes())
        data = out.read_bytes()
        if not kept:
            problems.append(f"{path.name}: {after.summary.changes_from(before.summary)}")
        if "CHANGED" in bytes_kept:
            problems.append(f"{path.name}: bytes other than positions changed")
        for text in (data, stdout.getvalue().encode(), stderr.getvalue().encode()):
            if b"meshwm" in text and text is data:
                problems.append(f"{path.name}: the output holds the bytes 'meshwm'")
            if KEY.encode() in text:
                problems.append(f"{path.name}: the key shows in an output")
        found = verify_asset(after, key=KEY, any_id=True)
        wanted = (
            {m: parse_id(i) for m, i in KIT_IDS.items()}
            if IDS[path.name] is None
            else {m.name: parse_id(str(IDS[path.name])) for m in before.meshes}
        )
        for row in found:
            ok = row["id"] == wanted[row["name"]].hex()
            shown = format_id(row["id"]) if row["id"] else "none"
            reads.append(
                f"{path.name:<18} {row['name']:<10} {shown:<34} {'exact' if ok else 'WRONG'}"
            )
            if not ok:
                problems.append(f"{path.name} [{row['name']}]: read {shown}")
        reads[-1] += f"   ({time.perf_counter() - started:.0f} s with embed)"
        table.append(
            ["", "", "", "", "", "", "", "", "", "all kept" if kept else "CHANGED", bytes_kept]
        )  # fmt: skip
    widths = [max(len(r[c]) for r in [header, *table]) for c in range(len(header))]
    print(" | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)))
    print("-|-".join("-" * w for w in widths))
    for r in table:
        print(" | ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))
    print()
    print(f"{'file':<18} {'mesh':<10} {'id read back (verify --any-id)':<34} vs embedded")
    print("\n".join(reads))
    print()
    print("no output holds 'meshwm' or the key" if not problems else "\n".join(problems))
    return 1 if problems else 0


def cli() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--keep", type=Path, help="build and keep the files in this folder")
    args = parser.parse_args()
    started = time.perf_counter()
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
        code = run(args.keep)
    else:
        with tempfile.TemporaryDirectory() as tmp:
            code = run(Path(tmp))
    print(f"\n{time.perf_counter() - started:.0f} s")
    return code


if __name__ == "__main__":
    sys.exit(cli())
