"""OFF documents: every line kept but the moved vertices' first three numbers.

The header (``OFF``, ``COFF``, ``NOFF``, ``STOFF``, ... and the counts), comments, vertex
colours, normals and texture coordinates after the position, and the faces (polygons, with
their colours) come out as they went in.  One vertex per line, as every writer does; binary
OFF is refused.  One mesh per file; polygons are fanned for marking only.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset, Summary, fan_triangles, group_sections
from meshwm.mesh.asset.numbers import infer_style

__all__ = ["read", "write"]

_KEYWORD = re.compile(rb"(ST)?(C)?(N)?(4)?(n)?OFF")
_SPACE = re.compile(rb"(\s+)")


def _data_lines(lines: list[bytes]) -> list[int]:
    """Indices of the lines that hold data (not blank, not a comment)."""
    return [k for k, line in enumerate(lines) if line.split(b"#", 1)[0].strip()]


def read(data: bytes, path: Path | None) -> Asset:
    """Parse an ASCII OFF file into an :class:`~meshwm.mesh.asset.document.Asset`."""
    lines = data.split(b"\n")
    useful = _data_lines(lines)
    if not useful:
        raise MeshError("file is empty")
    first = lines[useful[0]].split(b"#", 1)[0].split()
    keyword = _KEYWORD.fullmatch(first[0]) if first else None
    if keyword is None:
        raise MeshError("not an OFF file (no OFF keyword)")
    if keyword.group(4) or keyword.group(5):
        raise MeshError("OFF files with 4D or n-D vertices are not supported")
    counts = first[1:]
    cursor = 1
    if len(counts) < 2:
        counts = lines[useful[1]].split(b"#", 1)[0].split() if len(useful) > 1 else []
        cursor = 2
    if b"BINARY" in counts[:1]:
        raise MeshError("binary OFF files are not supported")
    try:
        n_vertices, n_faces = int(counts[0]), int(counts[1])
    except (ValueError, IndexError):
        raise MeshError("OFF header lacks the vertex and face counts") from None
    if len(useful) < cursor + n_vertices + n_faces:
        raise MeshError("OFF file has fewer lines than its header declares (truncated?)")
    vertex_lines = useful[cursor : cursor + n_vertices]
    face_lines = useful[cursor + n_vertices : cursor + n_vertices + n_faces]
    try:
        words = [lines[k].split(b"#", 1)[0].split() for k in vertex_lines]
        positions = np.array([[float(w[0]), float(w[1]), float(w[2])] for w in words])
        corners: list[int] = []
        lengths: list[int] = []
        for k in face_lines:
            w = lines[k].split(b"#", 1)[0].split()
            n = int(w[0])
            corners.extend(int(i) for i in w[1 : 1 + n])
            lengths.append(n)
            if len(w) < 1 + n:
                raise ValueError("short face")
    except (ValueError, IndexError):
        raise MeshError("OFF vertex or face line is malformed (truncated or corrupt?)") from None
    positions = positions.reshape(-1, 3)
    if not np.isfinite(positions).all():
        raise MeshError("NaN or infinite vertex coordinates")
    if not lengths or min(lengths) < 3:
        raise MeshError("OFF file has no faces, or a face with fewer than 3 vertices")
    tri, _ = fan_triangles(corners, lengths)
    meshes = group_sections(positions, [("", tri, len(lengths))])
    style = infer_style([t for w in words[:10_000] for t in w[:3]], positions)
    summary = Summary(
        meshes=len(meshes),
        vertices=len(positions),
        faces=len(lengths),
        triangles=len(tri),
        polygons=sum(1 for n in lengths if n > 3),
        uvs=len(positions) if keyword.group(1) else 0,
        normals=len(positions) if keyword.group(3) else 0,
        colors=len(positions) if keyword.group(2) else 0,
        dtype=f"text, {style.digits} decimals",
    )
    state = (vertex_lines, style)
    return Asset(".off", data, positions, positions.copy(), tuple(meshes), summary, state, path)


def write(asset: Asset) -> bytes:
    """The file's bytes with the moved vertices' coordinates rewritten."""
    vertex_lines, style = asset.state
    lines = asset.data.split(b"\n")
    rows = np.flatnonzero(asset.changed_rows())
    text = style.format(asset.positions[rows].ravel())
    for k, row in enumerate(rows.tolist()):
        number = vertex_lines[row]
        parts = _SPACE.split(lines[number])
        offset = 1 if parts and parts[0] == b"" else 0
        for c in range(3):
            parts[offset + 2 * c] = text[3 * k + c].encode()
        lines[number] = b"".join(parts)
    return b"\n".join(lines)
