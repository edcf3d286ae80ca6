"""STL documents: header, attribute bytes and every facet kept; moved corners rewritten.

STL stores each triangle's three corners (no shared vertices); corners at exactly the same
position are one vertex for marking and move together, so the file stays as welded as it was.
A facet whose corners moved gets its normal recomputed (a zero normal stays zero).  Binary
files keep their 80-byte header, their attribute words and float32; ASCII files keep every
line but the moved ``vertex`` and ``facet normal`` lines, and each ``solid`` is a mesh.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset, Summary, group_sections
from meshwm.mesh.asset.numbers import infer_style

__all__ = ["read", "write"]

_HEADER = 84
_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
_VERTEX = re.compile(rb"(vertex[ \t]+)(\S+)([ \t]+)(\S+)([ \t]+)(\S+)", re.IGNORECASE)
_NORMAL = re.compile(rb"(facet[ \t]+normal[ \t]+)(\S+)([ \t]+)(\S+)([ \t]+)(\S+)", re.IGNORECASE)
_SOLID = re.compile(rb"^[ \t]*solid\b[ \t]*([^\r\n]*)", re.IGNORECASE | re.MULTILINE)


def _is_binary(data: bytes) -> bool:
    if len(data) < _HEADER:
        return False
    (count,) = struct.unpack_from("<I", data, 80)
    return len(data) == _HEADER + _RECORD.itemsize * count


def _normals(corners: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit normals of (m, 3, 3) triangles (zero for degenerate ones)."""
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(cross, axis=1, keepdims=True)
    return np.divide(cross, length, out=np.zeros_like(cross), where=length > 0)


def read(data: bytes, path: Path | None) -> Asset:
    """Parse a binary or ASCII STL file into an :class:`~meshwm.mesh.asset.document.Asset`."""
    if _is_binary(data):
        records = np.frombuffer(data, _RECORD, offset=_HEADER)
        positions = records["corners"].reshape(-1, 3).astype(np.float64)
        sections = [("", np.arange(len(positions)).reshape(-1, 3), len(records))]
        state: tuple = ("binary",)
        dtype = "float32 binary"
    else:
        matches = list(_VERTEX.finditer(data))
        if not matches or len(matches) % 3:
            raise MeshError("ASCII STL has no facets, or a facet without three vertices")
        try:
            positions = np.array(
                [[float(m.group(k)) for k in (2, 4, 6)] for m in matches], dtype=np.float64
            )
        except ValueError:
            raise MeshError("ASCII STL has a vertex that is not three numbers") from None
        solids = list(_SOLID.finditer(data))
        starts = np.array([m.start() for m in solids] or [0])
        where = np.array([m.start() for m in matches])
        solid_of = np.searchsorted(starts, where, side="right") - 1
        solid_of = solid_of[::3]
        sections = []
        for s in range(len(starts)):
            tri = np.flatnonzero(solid_of == s)
            name = solids[s].group(1).strip().decode("utf-8", "replace") if solids else ""
            sections.append((name, (3 * tri[:, None] + np.arange(3)).astype(np.int64), len(tri)))
        tokens = [m.group(k) for m in matches[:10_000] for k in (2, 4, 6)]
        normals = list(_NORMAL.finditer(data))
        state = ("ascii", matches, normals, infer_style(tokens, positions))
        dtype = "text"
    if not np.isfinite(positions).all():
        raise MeshError("NaN or infinite vertex coordinates")
    meshes = group_sections(positions, sections)
    summary = Summary(
        meshes=len(meshes),
        vertices=len(positions),
        faces=len(positions) // 3,
        triangles=len(positions) // 3,
        dtype=dtype,
    )
    return Asset(".stl", data, positions, positions.copy(), tuple(meshes), summary, state, path)


def write(asset: Asset) -> bytes:
    """The file's bytes with moved corners (and their facets' normals) rewritten."""
    changed = asset.changed_rows().reshape(-1, 3).any(axis=1)
    facets = np.flatnonzero(changed)
    corners = asset.positions.reshape(-1, 3, 3)[facets]
    if asset.state[0] == "binary":
        out = bytearray(asset.data)
        records = np.frombuffer(out, _RECORD, offset=_HEADER)
        records["corners"][facets] = corners.astype(np.float32)
        stored = records["corners"][facets].astype(np.float64)
        keep_zero = ~records["normal"][facets].any(axis=1)
        unit = _normals(stored)
        unit[keep_zero] = 0.0
        records["normal"][facets] = unit.astype(np.float32)
        return bytes(out)
    _, matches, normal_matches, style = asset.state
    edits: list[tuple[int, int, bytes]] = []
    rows = np.flatnonzero(asset.changed_rows())
    text = style.format(asset.positions[rows].ravel())
    for k, row in enumerate(rows.tolist()):
        m = matches[row]
        x, y, z = (t.encode() for t in text[3 * k : 3 * k + 3])
        edits.append((m.start(), m.end(), m.group(1) + x + m.group(3) + y + m.group(5) + z))
    if len(normal_matches) == len(matches) // 3:
        normals = _normals(corners)
        for f, n in zip(facets.tolist(), normals, strict=True):
            m = normal_matches[f]
            if not any(float(m.group(k)) for k in (2, 4, 6)):
                continue
            a, b, c = (t.encode() for t in style.format(n))
            edits.append((m.start(), m.end(), m.group(1) + a + m.group(3) + b + m.group(5) + c))
    edits.sort()
    pieces, last = [], 0
    for start, end, new in edits:
        pieces += [asset.data[last:start], new]
        last = end
    pieces.append(asset.data[last:])
    return b"".join(pieces)
