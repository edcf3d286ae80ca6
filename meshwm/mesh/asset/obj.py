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


class _Scan:
    """One pass over the lines of an OBJ file: what marking needs, and the counts to report."""

    def __init__(self) -> None:
        self.v_lines: list[int] = []
        self.coords: list[tuple[float, float, float]] = []
        self.tokens: list[bytes] = []
        self.counts = {"vt": 0, "vn": 0, "colored": 0, "lines": 0}
        self.corners: list[int] = []
        self.lengths: list[int] = []
        self.face_section: list[int] = []
        self.sections: dict[tuple[bytes, bytes], int] = {}
        self.names = [b"", b""]  # the current object and group
        self.has_objects = False
        self.materials: set[bytes] = set()
        self.libraries: list[str] = []
        self.section = -1

    def vertex(self, number: int, rest: bytes) -> None:
        words = rest.split()
        try:
            xyz = (float(words[0]), float(words[1]), float(words[2]))
        except (ValueError, IndexError):
            raise MeshError(f"OBJ line {number}: a vertex needs three numbers") from None
        self.v_lines.append(number - 1)
        self.coords.append(xyz)
        if len(self.tokens) < 30_000:
            self.tokens.extend(words[:3])
        if len(words) >= 6:
            self.counts["colored"] += 1

    def face(self, number: int, rest: bytes) -> None:
        if self.section < 0:
            key = (self.names[0], self.names[1])
            self.section = self.sections.setdefault(key, len(self.sections))
        n_here = len(self.v_lines)
        count = 0
        for word in rest.split():
            try:
                index = int(word.split(b"/", 1)[0])
            except ValueError:
                raise MeshError(f"OBJ line {number}: bad face corner {word[:20]!r}") from None
            if index == 0:
                raise MeshError(f"OBJ line {number}: index 0 (OBJ indices start at 1)")
            self.corners.append(index - 1 if index > 0 else n_here + index)
            count += 1
        if count < 3:
            raise MeshError(f"OBJ line {number}: a face needs at least 3 vertices")
        self.lengths.append(count)
        self.face_section.append(self.section)

    def line(self, number: int, raw: bytes) -> None:
        line = raw.strip()
        if not line or line[:1] == b"#":
            return
        if line.endswith(b"\\"):
            raise MeshError(f"OBJ line {number} continues on the next line (\\); not supported")
        keyword, *others = line.split(None, 1)
        rest = others[0] if others else b""
        if keyword == b"v":
            self.vertex(number, rest)
        elif keyword == b"f":
            self.face(number, rest)
        elif keyword in (b"vt", b"vn"):
            self.counts[keyword.decode()] += 1
        elif keyword in (b"o", b"g"):
            self.names[keyword == b"g"] = rest.strip()
            self.has_objects |= keyword == b"o"
            self.section = -1
        elif keyword == b"usemtl":
            self.materials.add(rest.strip())
        elif keyword == b"mtllib":
            self.libraries.extend(w.decode("utf-8", "replace") for w in rest.split())
        elif keyword in (b"l", b"p"):
            self.counts["lines"] += 1

    def parts(self, tri: np.ndarray, owner: np.ndarray) -> list[tuple[str, np.ndarray, int]]:
        """(name, triangles, polygons) per object, or per group when there is no object."""
        by_key: dict[bytes, list[int]] = {}
        for s, (o_name, g_name) in enumerate(self.sections):
            by_key.setdefault(o_name if self.has_objects else g_name, []).append(s)
        polygon_section = np.asarray(self.face_section, dtype=np.int64)
        tri_section = polygon_section[owner]
        return [
            (
                name.decode("utf-8", "replace"),
                tri[np.isin(tri_section, members)],
                int(np.isin(polygon_section, members).sum()),
            )
            for name, members in by_key.items()
        ]


def read(data: bytes, path: Path | None) -> Asset:
    """Parse an OBJ file into an :class:`~meshwm.mesh.asset.document.Asset`."""
    scan = _Scan()
    for number, raw in enumerate(data.split(b"\n"), start=1):
        scan.line(number, raw)
    if not scan.lengths:
        raise MeshError("file contains no faces (empty, truncated or only points?)")
    positions = np.asarray(scan.coords, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(positions).all():
        raise MeshError("NaN or infinite vertex coordinates")
    tri, owner = fan_triangles(scan.corners, scan.lengths)
    if tri.min() < 0 or tri.max() >= len(positions):
        raise MeshError(
            f"a face refers to a vertex that does not exist ({len(positions)} vertices)"
        )
    meshes = group_sections(positions, scan.parts(tri, owner))
    style = infer_style(scan.tokens, positions)
    sidecars = list(scan.libraries)
    if path is not None:
        for library in scan.libraries:
            sidecars.extend(_texture_files(path.parent / library))
    extra = [f"mtllib={' '.join(scan.libraries)}"] if scan.libraries else []
    if scan.counts["lines"]:
        extra.append(f"lines/points={scan.counts['lines']}")
    summary = Summary(
        meshes=len(meshes),
        vertices=len(positions),
        faces=len(scan.lengths),
        triangles=len(tri),
        polygons=sum(1 for n in scan.lengths if n > 3),
        uvs=scan.counts["vt"],
        normals=scan.counts["vn"],
        colors=scan.counts["colored"],
        materials=len(scan.materials),
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
        state=(np.asarray(scan.v_lines, dtype=np.int64), style),
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
