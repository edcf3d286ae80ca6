"""OBJ documents: every line kept byte for byte but the ``v`` records whose position moved.

``vt``, ``vn``, ``mtllib``, ``usemtl``, ``o``, ``g``, ``s``, comments, polygons, lines: all
stay as they are (the material library and its textures are other files, never touched).  A
rewritten ``v`` record keeps its indentation, its separators and anything after the third
coordinate (a ``w`` or vertex colours), and writes the coordinates in the file's own style
(:mod:`meshwm.mesh.asset.numbers`).

Meshes: the ``o`` objects when the file has any, else the ``g`` groups, else one mesh; objects
that share a ``v`` record are one mesh (a position cannot move two ways).  Polygons are fanned
into triangles for marking only; the file keeps its polygons.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset, Summary, fan_triangles, group_sections
from meshwm.mesh.asset.numbers import infer_style

__all__ = ["read", "write"]

_V_RECORD = re.compile(rb"^(\s*v\s+)(\S+)(\s+)(\S+)(\s+)(\S+)(.*)$", re.DOTALL)
#: What an older meshwm wrote at the top of an OBJ file; dropped, the file names no tool.
_OLD_SIGNATURE = b"# written by meshwm"


def _texture_files(mtl: Path) -> list[str]:
    """The texture files a material library names (``map_*``, ``bump``, ``disp``, ``refl``)."""
    try:
        text = mtl.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    out = []
    for line in text.splitlines():
        words = line.split()
        if len(words) >= 2 and (words[0].lower().startswith("map_") or words[0].lower() in (
            "bump", "disp", "refl", "decal", "norm"
        )):  # fmt: skip
            out.append(words[-1])
    return out


def read(data: bytes, path: Path | None) -> Asset:
    """Parse an OBJ file into an :class:`~meshwm.mesh.asset.document.Asset`."""
    lines = data.split(b"\n")
    v_lines: list[int] = []
    coords: list[tuple[float, float, float]] = []
    tokens: list[bytes] = []
    n_vt = n_vn = n_colored = 0
    flat: list[int] = []
    lengths: list[int] = []
    face_section: list[int] = []
    sections: dict[tuple[bytes, bytes], int] = {}
    obj_name = group_name = b""
    has_objects = False
    materials: set[bytes] = set()
    libraries: list[str] = []
    n_lines_records = 0
    section = -1
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line[:1] == b"#":
            continue
        if line.endswith(b"\\"):
            raise MeshError(f"OBJ line {number} continues on the next line (\\); not supported")
        keyword, *others = line.split(None, 1)
        rest = others[0] if others else b""
        if keyword == b"v":
            words = rest.split()
            try:
                xyz = (float(words[0]), float(words[1]), float(words[2]))
            except (ValueError, IndexError):
                raise MeshError(f"OBJ line {number}: a vertex needs three numbers") from None
            v_lines.append(number - 1)
            coords.append(xyz)
            if len(tokens) < 30_000:
                tokens.extend(words[:3])
            if len(words) >= 6:
                n_colored += 1
        elif keyword == b"f":
            if section < 0:
                section = sections.setdefault((obj_name, group_name), len(sections))
            n_here = len(v_lines)
            count = 0
            for word in rest.split():
                try:
                    index = int(word.split(b"/", 1)[0])
                except ValueError:
                    raise MeshError(f"OBJ line {number}: bad face corner {word[:20]!r}") from None
                if index == 0:
                    raise MeshError(f"OBJ line {number}: index 0 (OBJ indices start at 1)")
                flat.append(index - 1 if index > 0 else n_here + index)
                count += 1
            if count < 3:
                raise MeshError(f"OBJ line {number}: a face needs at least 3 vertices")
            lengths.append(count)
            face_section.append(section)
        elif keyword == b"vt":
            n_vt += 1
        elif keyword == b"vn":
            n_vn += 1
        elif keyword in (b"o", b"g"):
            name = rest.strip()
            if keyword == b"o":
                obj_name, has_objects = name, True
            else:
                group_name = name
            section = -1
        elif keyword == b"usemtl":
            materials.add(rest.strip())
        elif keyword == b"mtllib":
            libraries.extend(w.decode("utf-8", "replace") for w in rest.split())
        elif keyword in (b"l", b"p"):
            n_lines_records += 1
    if not lengths:
        raise MeshError("file contains no faces (empty, truncated or only points?)")
    positions = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(positions).all():
        raise MeshError("NaN or infinite vertex coordinates")
    tri, owner = fan_triangles(flat, lengths)
    if tri.min() < 0 or tri.max() >= len(positions):
        raise MeshError(
            f"a face refers to a vertex that does not exist ({len(positions)} vertices)"
        )
    keys = list(sections)
    by_key: dict[bytes, list[int]] = {}
    for s, (o_name, g_name) in enumerate(keys):
        by_key.setdefault(o_name if has_objects else g_name, []).append(s)
    tri_section = np.asarray(face_section, dtype=np.int64)[owner]
    polygon_section = np.asarray(face_section, dtype=np.int64)
    parts = []
    for name, members in by_key.items():
        mask = np.isin(tri_section, members)
        parts.append(
            (
                name.decode("utf-8", "replace"),
                tri[mask],
                int(np.isin(polygon_section, members).sum()),
            )
        )
    meshes = group_sections(positions, parts)
    style = infer_style(tokens, positions)
    sidecars = list(libraries)
    if path is not None:
        for library in libraries:
            sidecars.extend(_texture_files(path.parent / library))
    extra = [f"mtllib={' '.join(libraries)}"] if libraries else []
    if n_lines_records:
        extra.append(f"lines/points={n_lines_records}")
    summary = Summary(
        meshes=len(meshes),
        vertices=len(positions),
        faces=len(lengths),
        triangles=len(tri),
        polygons=sum(1 for n in lengths if n > 3),
        uvs=n_vt,
        normals=n_vn,
        colors=n_colored,
        materials=len(materials),
        dtype=f"text, {'exponent ' if style.exponent else ''}{style.digits} decimals",
        extra=tuple(extra),
    )
    return Asset(
        ".obj",
        data,
        positions,
        positions.copy(),
        tuple(meshes),
        summary,
        state=(np.asarray(v_lines, dtype=np.int64), style),
        path=path,
        sidecars=tuple(dict.fromkeys(sidecars)),
    )


def write(asset: Asset) -> bytes:
    """The file's bytes with the moved ``v`` records rewritten (and no old tool signature)."""
    v_lines, style = asset.state
    lines = asset.data.split(b"\n")
    changed = np.flatnonzero(asset.changed_rows())
    if len(changed):
        text = style.format(asset.positions[changed].ravel())
        for k, row in enumerate(changed.tolist()):
            number = int(v_lines[row])
            match = _V_RECORD.match(lines[number])
            if match is None:  # pragma: no cover - read() accepted this line as a vertex
                raise MeshError(f"OBJ line {number + 1}: cannot rewrite the vertex")
            head, _, s1, _, s2, _, tail = match.groups()
            x, y, z = text[3 * k : 3 * k + 3]
            lines[number] = b"".join([head, x.encode(), s1, y.encode(), s2, z.encode(), tail])
    kept = [ln for ln in lines if ln.rstrip(b"\r") != _OLD_SIGNATURE]
    return b"\n".join(kept)
