"""PLY documents: the header and every element kept; only the x, y, z of moved vertices change.

Binary files keep their bytes but the moved vertices' ``x``, ``y``, ``z``, rewritten in the
file's own type and byte order (a ``float`` file stays float32); ASCII files keep every line
but the moved vertices' rows, where only the three coordinate tokens change (in the file's
number style, :mod:`meshwm.mesh.asset.numbers`).  Colours, normals, UVs, any other vertex or
face property and any other element come out as they went in.  One mesh per file; polygons
are fanned for marking only.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import Any

import numpy as np

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset, Summary, fan_triangles, group_sections
from meshwm.mesh.asset.numbers import infer_style
from meshwm.mesh.io.ply import PlyElement, parse_header

__all__ = ["read", "write"]

_NUMPY = {
    "char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
    "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
    "int32": "i4", "uint32": "u4", "int64": "i8", "uint64": "u8", "float16": "f2",
    "float32": "f4", "float64": "f8",
}  # fmt: skip
_INDEX_NAMES = ("vertex_indices", "vertex_index")
_COLOR_NAMES = {"red", "green", "blue", "alpha", "r", "g", "b", "a"}
_COLOR_NAMES |= {f"diffuse_{c}" for c in ("red", "green", "blue", "alpha")}
_NORMAL_NAMES = {"nx", "ny", "nz"}
_UV_NAMES = {"u", "v", "s", "t", "texture_u", "texture_v", "texture_s", "texture_t"}
_OLD_SIGNATURE = b"comment written by meshwm"
_SPACE = re.compile(rb"(\s+)")


def _scalar_dtype(element: PlyElement, order: str) -> np.dtype:
    return np.dtype([(name, order + _NUMPY[kind]) for name, kind, _ in element.properties])


def _face_lists_binary(
    data: bytes, offset: int, element: PlyElement, order: str
) -> tuple[list[int], list[int], int]:
    """The index lists of a binary face element (corners, lengths) and its end offset."""
    props = element.properties
    lists = [k for k, (_, _, count_type) in enumerate(props) if count_type]
    index = _index_list(element)
    n = element.count
    # Fast path: every list as long as the first one (triangles, quads): one structured read.
    if len(lists) == 1 and n:
        fields: list[tuple[str, str] | tuple[str, str, tuple[int]]] = []
        pos = offset
        width = 0
        for k, (_name, kind, count_type) in enumerate(props):
            if k == index:
                count_dt = np.dtype(order + _NUMPY[str(count_type)])
                width = int(np.frombuffer(data, count_dt, 1, pos)[0])
                fields.append(("count", order + _NUMPY[str(count_type)]))
                if width:
                    fields.append(("items", order + _NUMPY[kind], (width,)))
            else:
                fields.append((f"p{k}", order + _NUMPY[kind]))
                pos += np.dtype(_NUMPY[kind]).itemsize
        row = np.dtype(fields)
        if offset + n * row.itemsize <= len(data) and width >= 3:
            table = np.frombuffer(data, row, n, offset)
            if np.all(table["count"] == width):
                uniform = table["items"].astype(np.int64).ravel().tolist()
                return uniform, [width] * n, offset + n * row.itemsize
    corners: list[int] = []
    lengths: list[int] = []
    pos = offset
    try:
        for _ in range(n):
            for k, (_, kind, count_type) in enumerate(props):
                size = np.dtype(_NUMPY[kind]).itemsize
                if count_type is None:
                    pos += size
                    continue
                (length,) = struct.unpack_from(order + _struct_code(count_type), data, pos)
                pos += np.dtype(_NUMPY[count_type]).itemsize
                if k == index:
                    items = np.frombuffer(data, order + _NUMPY[kind], length, pos)
                    corners.extend(items.astype(np.int64).tolist())
                    lengths.append(int(length))
                pos += size * int(length)
    except (struct.error, ValueError):
        raise MeshError(f"PLY {element.name} data is truncated") from None
    return corners, lengths, pos


def _struct_code(kind: str) -> str:
    return {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "i8": "q",
            "u8": "Q", "f2": "e", "f4": "f", "f8": "d"}[_NUMPY[kind]]  # fmt: skip


def _walk_binary(
    data: bytes, start: int, elements: list[PlyElement], order: str
) -> tuple[dict[str, int], list[int], list[int]]:
    """Offsets of every element's data, and the face lists."""
    offsets: dict[str, int] = {}
    corners: list[int] = []
    lengths: list[int] = []
    pos = start
    for element in elements:
        offsets[element.name] = pos
        if any(count_type for _, _, count_type in element.properties):
            got = _face_lists_binary(data, pos, element, order)
            if element.name == "face":
                corners, lengths = got[0], got[1]
            pos = got[2]
        else:
            pos += element.count * _scalar_dtype(element, order).itemsize
        if pos > len(data):
            raise MeshError(f"PLY {element.name} data is truncated")
    if data[pos:].strip():
        raise MeshError(
            f"PLY file has {len(data) - pos} bytes after its last element (corrupt header?)"
        )
    return offsets, corners, lengths


def _ascii_rows(
    data: bytes, start: int, elements: list[PlyElement]
) -> tuple[list[bytes], dict[str, int]]:
    lines = data[start:].split(b"\n")
    rows: dict[str, int] = {}
    line = 0
    for element in elements:
        while line < len(lines) and not lines[line].strip() and element.count:
            line += 1
        rows[element.name] = line
        line += element.count
    return lines, rows


def _index_list(element: PlyElement) -> int:
    """Which property of a face element holds the vertex indices."""
    props = element.properties
    lists = [k for k, (_, _, count_type) in enumerate(props) if count_type]
    if not lists:
        raise MeshError(f"PLY element {element.name!r} has no list of vertex indices")
    return next((k for k in lists if props[k][0] in _INDEX_NAMES), lists[0])


def _ascii_faces(
    lines: list[bytes], first: int, element: PlyElement
) -> tuple[list[int], list[int]]:
    corners: list[int] = []
    lengths: list[int] = []
    index = _index_list(element)
    for text in lines[first : first + element.count]:
        words = text.split()
        pos = 0
        for k, (_, _, count_type) in enumerate(element.properties):
            if count_type is None:
                pos += 1
                continue
            length = int(words[pos])
            if k == index:
                corners.extend(int(w) for w in words[pos + 1 : pos + 1 + length])
                lengths.append(length)
            pos += 1 + length
    return corners, lengths


def _summary(
    elements: list[PlyElement],
    encoding: str,
    x_type: str,
    meshes: int,
    n_tri: int,
    lengths: list[int],
) -> Summary:
    by_name = {e.name: e for e in elements}
    vertex = by_name["vertex"]
    names = {name for name, _, _ in vertex.properties}
    extra = [
        f"vertex.{n}"
        for n, _, _ in vertex.properties
        if n not in {"x", "y", "z"} | _COLOR_NAMES | _NORMAL_NAMES | _UV_NAMES
    ]
    for e in elements:
        if e.name == "vertex":
            continue
        props = [n for n, _, _ in e.properties if n not in _INDEX_NAMES]
        extra.append(f"{e.name}={e.count}" + (f"({','.join(props)})" if props else ""))
    n = vertex.count
    return Summary(
        meshes=meshes,
        vertices=n,
        faces=len(lengths),
        triangles=n_tri,
        polygons=sum(1 for k in lengths if k > 3),
        uvs=n if names & _UV_NAMES else 0,
        normals=n if names & _NORMAL_NAMES else 0,
        colors=n if names & _COLOR_NAMES else 0,
        materials=0,
        dtype=f"{np.dtype(_NUMPY[x_type]).name} {encoding}",
        extra=tuple(extra),
    )


def read(data: bytes, path: Path | None) -> Asset:
    """Parse a PLY file into an :class:`~meshwm.mesh.asset.document.Asset`."""
    try:
        encoding, elements, start = parse_header(data)
    except ValueError as exc:
        raise MeshError(str(exc)) from None
    by_name = {e.name: e for e in elements}
    vertex, face = by_name.get("vertex"), by_name.get("face")
    if vertex is None or face is None or not face.count:
        raise MeshError("file contains no faces (empty, truncated or only points?)")
    kinds = {name: kind for name, kind, _ in vertex.properties}
    if any(count_type for _, _, count_type in vertex.properties):
        raise MeshError("PLY vertices with list properties are not supported")
    if not {"x", "y", "z"} <= set(kinds):
        raise MeshError("PLY vertex element lacks x, y or z")
    if not kinds["x"].startswith(("float", "double")):
        raise MeshError(f"PLY positions are stored as {kinds['x']}; a mark needs float or double")
    state: dict[str, Any] = {"encoding": encoding, "start": start, "elements": elements}
    tokens: list[bytes] = []
    try:
        if encoding == "ascii":
            lines, rows = _ascii_rows(data, start, elements)
            first = rows["vertex"]
            columns = [[name for name, _, _ in vertex.properties].index(c) for c in "xyz"]
            words = [lines[first + i].split() for i in range(vertex.count)]
            tokens = [w[c] for w in words[:10_000] for c in columns]
            positions = np.array([[float(w[c]) for c in columns] for w in words], dtype=np.float64)
            corners, lengths = _ascii_faces(lines, rows["face"], face)
            state.update(first=first, columns=columns, style=infer_style(tokens, positions))
        else:
            order = "<" if encoding == "binary_little_endian" else ">"
            offsets, corners, lengths = _walk_binary(data, start, elements, order)
            table = np.frombuffer(
                data, _scalar_dtype(vertex, order), vertex.count, offsets["vertex"]
            )
            positions = np.stack([table[c].astype(np.float64) for c in "xyz"], axis=1)
            state.update(order=order, offset=offsets["vertex"])
    except (IndexError, ValueError) as exc:
        if isinstance(exc, MeshError):
            raise
        raise MeshError(f"cannot read PLY {encoding} data, truncated or corrupt? ({exc})") from None
    positions = positions.reshape(-1, 3)
    if not np.isfinite(positions).all():
        raise MeshError("NaN or infinite vertex coordinates")
    if min(lengths, default=3) < 3:
        raise MeshError("a PLY face has fewer than 3 vertices")
    tri, _ = fan_triangles(corners, lengths)
    meshes = group_sections(positions, [("", tri, len(lengths))])
    summary = _summary(elements, encoding, kinds["x"], len(meshes), len(tri), lengths)
    return Asset(".ply", data, positions, positions.copy(), tuple(meshes), summary, state, path)


def _without_signature(header: bytes) -> bytes:
    return b"".join(
        line for line in header.splitlines(keepends=True) if line.rstrip(b"\r\n") != _OLD_SIGNATURE
    )


def write(asset: Asset) -> bytes:
    """The file's bytes with the moved vertices' x, y, z rewritten in its own type."""
    state = asset.state
    start: int = state["start"]
    header, body = asset.data[:start], asset.data[start:]
    changed = np.flatnonzero(asset.changed_rows())
    vertex = next(e for e in state["elements"] if e.name == "vertex")
    if state["encoding"] != "ascii":
        out = bytearray(asset.data)
        table = np.frombuffer(
            out, _scalar_dtype(vertex, state["order"]), vertex.count, state["offset"]
        )
        for c, name in enumerate("xyz"):
            column = table[name]
            column[changed] = asset.positions[changed, c].astype(column.dtype)
        return _without_signature(header) + bytes(out[start:])
    lines = body.split(b"\n")
    text = state["style"].format(asset.positions[changed].ravel())
    for k, row in enumerate(changed.tolist()):
        number = state["first"] + row
        parts = _SPACE.split(lines[number])
        offset = 1 if parts and parts[0] == b"" else 0  # leading whitespace
        for c, column in enumerate(state["columns"]):
            parts[offset + 2 * column] = text[3 * k + c].encode()
        lines[number] = b"".join(parts)
    return _without_signature(header) + b"\n".join(lines)
