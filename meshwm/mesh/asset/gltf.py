"""glTF 2 documents (``.glb`` and ``.gltf``): only the position bytes and their bounds change.

The scene graph (nodes, names, transforms, hierarchy), meshes and primitives, materials,
textures and images, UVs, normals, colours, skins, morph targets, animations, extensions and
extras are not parsed into anything: the JSON is kept as it is but for the ``min``/``max`` of
the position accessors that moved (glTF requires them), and the binary buffers byte for byte
but for the moved positions, written as float32 where they were.  A ``.gltf`` file's changed
external buffer is embedded in the output as a data URI (the input's ``.bin`` is never
written); unchanged external buffers and images stay references (see ``sidecars``).

Meshes: each glTF mesh is one (its primitives together), named after the node that uses it
when exactly one named node does, else after the mesh; meshes that share a position accessor
are one.  Positions are marked in the mesh's own frame (the node transforms are kept, and
the reader is indifferent to a similarity).  Draco- or meshopt-compressed and quantised
(integer) positions cannot be marked: such meshes are reported with the reason.
"""

from __future__ import annotations

import base64
import json
import struct
import urllib.parse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset, AssetMesh, Summary, group_sections

__all__ = ["read", "write"]

_COMPONENT = {5120: "i1", 5121: "u1", 5122: "i2", 5123: "u2", 5125: "u4", 5126: "f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_JSON, _BIN = 0x4E4F534A, 0x004E4942
_COMPRESSED = ("KHR_draco_mesh_compression", "EXT_meshopt_compression")


def _split_glb(data: bytes) -> tuple[dict, bytes | None]:
    if len(data) < 20 or data[:4] != b"glTF":
        raise MeshError("not a GLB file (no 'glTF' magic)")
    _, version, length = struct.unpack_from("<4sII", data)
    if version != 2 or length > len(data):
        raise MeshError("unsupported or truncated GLB file")
    pos, gltf, binary = 12, None, None
    while pos + 8 <= length:
        size, kind = struct.unpack_from("<II", data, pos)
        chunk = data[pos + 8 : pos + 8 + size]
        if len(chunk) != size:
            raise MeshError("GLB chunk is truncated")
        if kind == _JSON and gltf is None:
            gltf = _parse_json(chunk)
        elif kind == _BIN and binary is None:
            binary = chunk
        pos += 8 + size
    if gltf is None:
        raise MeshError("GLB has no JSON chunk")
    return gltf, binary


def _parse_json(text: bytes) -> dict:
    try:
        gltf = json.loads(text)
    except (ValueError, RecursionError):
        raise MeshError("glTF JSON is not valid JSON (corrupt?)") from None
    if not isinstance(gltf, dict):
        raise MeshError("glTF JSON is not an object")
    return gltf


def _load_buffers(gltf: dict, binary: bytes | None, path: Path | None) -> list[bytes]:
    out = []
    for k, buffer in enumerate(gltf.get("buffers", [])):
        uri = buffer.get("uri") if isinstance(buffer, dict) else None
        if uri is None:
            if k != 0 or binary is None:
                raise MeshError(f"glTF buffer {k} has no data")
            out.append(binary)
        elif uri.startswith("data:"):
            try:
                out.append(base64.b64decode(uri.split(",", 1)[1], validate=True))
            except (ValueError, IndexError):
                raise MeshError(f"glTF buffer {k} has a malformed data URI") from None
        else:
            name = urllib.parse.unquote(uri)
            if "://" in uri or Path(name).is_absolute() or path is None:
                raise MeshError(f"glTF buffer {k} ({uri[:60]!r}) is not a file next to the glTF")
            try:
                out.append((path.parent / name).read_bytes())
            except OSError:
                raise MeshError(f"cannot read the glTF buffer {name!r}") from None
    return out


class _Layout:
    """Where an accessor's elements are: buffer, first byte, stride, count, dtype, width."""

    def __init__(self, gltf: dict, buffers: Sequence[bytes | bytearray], a: int) -> None:
        try:
            accessor = gltf["accessors"][a]
            view = gltf["bufferViews"][accessor["bufferView"]]
            self.buffer = int(view["buffer"])
            self.dtype = np.dtype("<" + _COMPONENT[int(accessor["componentType"])])
            self.width = _WIDTH[accessor["type"]]
            self.count = int(accessor["count"])
            self.start = int(view.get("byteOffset", 0)) + int(accessor.get("byteOffset", 0))
            self.stride = int(view.get("byteStride", 0)) or self.dtype.itemsize * self.width
        except (KeyError, IndexError, TypeError, ValueError):
            raise MeshError(f"glTF accessor {a} is malformed") from None
        end = self.start + self.stride * max(self.count - 1, 0) + self.dtype.itemsize * self.width
        if self.count and (self.buffer >= len(buffers) or end > len(buffers[self.buffer])):
            raise MeshError(f"glTF accessor {a} reaches past the end of its buffer")

    def view(self, buffer: bytes | bytearray) -> NDArray:
        """The (count, width) elements, as a strided view into ``buffer`` (writable if it is)."""
        return np.ndarray(
            shape=(self.count, self.width),
            dtype=self.dtype,
            buffer=buffer if self.count else None,
            offset=self.start if self.count else 0,
            strides=(self.stride, self.dtype.itemsize) if self.count else None,
        )


def _triangles(mode: int, index: NDArray[np.int64]) -> NDArray[np.int64]:
    if mode == 4:
        return index[: len(index) // 3 * 3].reshape(-1, 3)
    n = len(index) - 2
    if n <= 0:
        return np.zeros((0, 3), dtype=np.int64)
    k = np.arange(n)
    if mode == 5:  # strip: every other triangle turned over
        odd = k % 2 == 1
        a, b = np.where(odd, k + 1, k), np.where(odd, k, k + 1)
        return np.stack([index[a], index[b], index[k + 2]], axis=1)
    return np.stack([np.full(n, index[0]), index[k + 1], index[k + 2]], axis=1)  # fan


def _mesh_names(gltf: dict) -> list[str]:
    users: dict[int, list[str]] = {}
    for node in gltf.get("nodes", []):
        if isinstance(node, dict) and isinstance(node.get("mesh"), int):
            users.setdefault(node["mesh"], []).append(str(node.get("name", "")))
    names = []
    for m, mesh in enumerate(gltf.get("meshes", [])):
        nodes = users.get(m, [])
        if len(nodes) == 1 and nodes[0]:
            names.append(nodes[0])
        else:
            names.append(str(mesh.get("name", "")) or f"mesh{m}")
    return names


def _compressed(gltf: dict) -> bool:
    required = gltf.get("extensionsRequired", []) or []
    return any(name in required for name in _COMPRESSED)


def _parse_meshes(
    gltf: dict, buffers: list[bytes]
) -> tuple[NDArray[np.float64], dict[int, int], list[tuple[str, NDArray, int]], list[AssetMesh]]:
    """The position table, where each position accessor starts in it, sections, unmarkable."""
    chunks: list[NDArray] = []
    base: dict[int, int] = {}
    sections: list[tuple[str, NDArray, int]] = []
    unmarkable: list[AssetMesh] = []
    rows = 0
    empty = np.zeros(0, dtype=np.int64)
    for name, mesh in zip(_mesh_names(gltf), gltf.get("meshes", []), strict=True):
        tris: list[NDArray] = []
        polygons, reason = 0, None
        for prim in mesh.get("primitives", []):
            mode = int(prim.get("mode", 4))
            if mode not in (4, 5, 6):
                continue  # points and lines: not a surface
            a = prim.get("attributes", {}).get("POSITION")
            accessor = gltf["accessors"][a] if isinstance(a, int) else None
            if any(e in prim.get("extensions", {}) for e in _COMPRESSED) or _compressed(gltf):
                reason = "its positions are compressed (Draco or meshopt)"
            elif accessor is None or "bufferView" not in accessor or "sparse" in accessor:
                reason = "its positions are not stored as plain data (sparse or missing)"
            elif accessor.get("componentType") != 5126 or accessor.get("type") != "VEC3":
                reason = "its positions are quantised (integers), not float32"
            if reason:
                break
            layout = _Layout(gltf, buffers, a)
            if a not in base:
                base[a] = rows
                chunks.append(layout.view(buffers[layout.buffer]).astype(np.float64))
                rows += layout.count
            if "indices" in prim:
                index_layout = _Layout(gltf, buffers, int(prim["indices"]))
                index = index_layout.view(buffers[index_layout.buffer]).astype(np.int64).ravel()
            else:
                index = np.arange(layout.count, dtype=np.int64)
            if len(index) and (index.min() < 0 or index.max() >= layout.count):
                raise MeshError(f"glTF mesh {name!r} has an index past its vertices")
            tri = _triangles(mode, index)
            tris.append(tri + base[a])
            polygons += len(tri)
        if reason is not None:
            unmarkable.append(AssetMesh(name, empty, empty, np.zeros((0, 3), np.int64), 0, reason))
        elif tris:
            sections.append((name, np.concatenate(tris), polygons))
    table = np.concatenate(chunks) if chunks else np.zeros((0, 3))
    return table, base, sections, unmarkable


def _count(gltf: dict, attribute: str) -> int:
    seen: set[int] = set()
    for mesh in gltf.get("meshes", []):
        for prim in mesh.get("primitives", []):
            a = prim.get("attributes", {}).get(attribute)
            if isinstance(a, int):
                seen.add(a)
    return sum(int(gltf["accessors"][a].get("count", 0)) for a in seen)


def read(data: bytes, path: Path | None, *, binary: bool) -> Asset:
    """Parse a GLB (``binary``) or ``.gltf`` file into an :class:`~meshwm.mesh.asset.Asset`."""
    gltf, chunk = _split_glb(data) if binary else (_parse_json(data), None)
    buffers = _load_buffers(gltf, chunk, path)
    try:
        table, base, sections, unmarkable = _parse_meshes(gltf, buffers)
    except (KeyError, IndexError, TypeError, AttributeError, ValueError) as exc:
        if isinstance(exc, MeshError):
            raise
        raise MeshError(f"glTF meshes are malformed ({type(exc).__name__})") from None
    if not np.isfinite(table).all():
        raise MeshError("NaN or infinite vertex coordinates")
    meshes = group_sections(table, sections) + unmarkable
    if not meshes:
        raise MeshError("file contains no triangle meshes")
    counts = {
        k: len(gltf.get(k, [])) for k in ("nodes", "textures", "images", "skins", "animations")
    }
    summary = Summary(
        meshes=len(meshes),
        vertices=len(table),
        faces=sum(s[2] for s in sections),
        triangles=sum(len(s[1]) for s in sections),
        uvs=_count(gltf, "TEXCOORD_0"),
        normals=_count(gltf, "NORMAL"),
        colors=_count(gltf, "COLOR_0"),
        materials=len(gltf.get("materials", [])),
        dtype="float32 " + ("GLB" if binary else "glTF"),
        extra=tuple(f"{k}={n}" for k, n in counts.items() if n),
    )
    sidecars = [
        urllib.parse.unquote(item["uri"])
        for kind in ("buffers", "images")
        for item in gltf.get(kind, [])
        if isinstance(item, dict) and "uri" in item and not item["uri"].startswith("data:")
    ]
    state = {"gltf": gltf, "buffers": buffers, "base": base, "binary": binary}
    suffix = ".glb" if binary else ".gltf"
    return Asset(
        suffix, data, table, table.copy(), tuple(meshes), summary, state, path, tuple(sidecars)
    )


def _glb(json_bytes: bytes, binary: bytes | None) -> bytes:
    json_bytes += b" " * (-len(json_bytes) % 4)
    chunks = struct.pack("<II", len(json_bytes), _JSON) + json_bytes
    if binary is not None:
        binary = binary + b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<II", len(binary), _BIN) + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def write(asset: Asset) -> bytes:
    """The file with the moved positions (float32) and their accessors' bounds rewritten."""
    state: dict[str, Any] = asset.state
    changed = asset.changed_rows()
    if not changed.any():
        return asset.data
    gltf = json.loads(json.dumps(state["gltf"]))  # a copy; only min/max will differ
    buffers = [bytearray(b) for b in state["buffers"]]
    touched: set[int] = set()
    for a, start in state["base"].items():
        layout = _Layout(gltf, buffers, a)
        rows = slice(start, start + layout.count)
        if not changed[rows].any():
            continue
        view = layout.view(buffers[layout.buffer])
        view[...] = asset.positions[rows].astype(np.float32)
        stored = view.astype(np.float64)
        gltf["accessors"][a]["min"] = stored.min(axis=0).tolist()
        gltf["accessors"][a]["max"] = stored.max(axis=0).tolist()
        touched.add(layout.buffer)
    for k in touched:
        if gltf["buffers"][k].get("uri") is not None:
            encoded = base64.b64encode(bytes(buffers[k])).decode("ascii")
            gltf["buffers"][k]["uri"] = "data:application/octet-stream;base64," + encoded
    if state["binary"]:
        text = json.dumps(gltf, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
        return _glb(
            text, bytes(buffers[0]) if buffers and "uri" not in gltf["buffers"][0] else None
        )
    indent = 2 if b"\n" in asset.data.strip() else None
    return json.dumps(gltf, indent=indent, ensure_ascii=False).encode("utf-8")
