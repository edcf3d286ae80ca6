"""PLY: a strict header parser and pre-check, the list-length check after loading, the writer.

Reading refuses what trimesh would misread silently: absurd or impossible element counts,
ASCII rows whose list length disagrees with the first row, binary lists of inconsistent
lengths.  Writing gives binary little-endian PLY with float64 coordinates and int32 indices,
which round-trips exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.mesh.io.common import COUNT, Declared, vertex_limit

__all__ = ["PlyElement", "check_loaded", "parse_header", "precheck", "write"]

#: A PLY header longer than this is refused (real headers are a few hundred bytes).
_MAX_PLY_HEADER = 1 << 20

_PLY_TYPES = {
    "char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4,
    "float": 4, "double": 8, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
    "int32": 4, "uint32": 4, "int64": 8, "uint64": 8, "float16": 2, "float32": 4,
    "float64": 8,
}  # fmt: skip
_PLY_INT_TYPES = {name for name in _PLY_TYPES if not name.startswith(("float", "double"))}
_PLY_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")


@dataclass
class PlyElement:
    """One ``element`` of a PLY header: its name, row count and properties."""

    name: str
    count: int
    #: (name, scalar type, list-count type or None)
    properties: list[tuple[str, str, str | None]] = field(default_factory=list)


def parse_header(data: bytes) -> tuple[str, list[PlyElement], int]:
    """Strictly parse a PLY header; return (format, elements, offset of the data section).

    Raises :class:`ValueError` with a one-line message for anything but a well-formed header.
    """
    if not (data.startswith(b"ply\n") or data.startswith(b"ply\r\n")):
        raise ValueError("not a PLY file (the first line is not 'ply')")
    elements: list[PlyElement] = []
    encoding = ""
    pos = 0
    line_no = 0
    while True:
        end = data.find(b"\n", pos, _MAX_PLY_HEADER)
        if end < 0:
            raise ValueError("PLY header has no end_header line (truncated?)")
        raw, pos = data[pos:end], end + 1
        line_no += 1
        try:
            line = raw.decode("ascii").strip()
        except UnicodeDecodeError:
            raise ValueError(f"PLY header line {line_no} is not text (corrupt header?)") from None
        words = line.split()
        if line_no == 1:
            continue  # "ply", checked above
        if line_no == 2:
            if len(words) != 3 or words[0] != "format" or words[1] not in _PLY_FORMATS:
                raise ValueError(f"bad PLY format line {line[:40]!r}")
            if words[2] not in ("1.0", "1"):
                raise ValueError(f"unsupported PLY version {words[2][:20]!r}")
            encoding = words[1]
            continue
        if not words:
            raise ValueError(f"empty line {line_no} in the PLY header")
        keyword = words[0]
        if keyword == "end_header" and len(words) == 1:
            break
        if keyword in ("comment", "obj_info"):
            continue
        if keyword == "element":
            if len(words) != 3 or not COUNT.fullmatch(words[2]):
                raise ValueError(f"bad PLY element line {line[:60]!r} (count must be >= 0)")
            if any(e.name == words[1] for e in elements):
                raise ValueError(f"PLY element {words[1][:20]!r} is declared twice")
            elements.append(PlyElement(words[1], int(words[2])))
        elif keyword == "property":
            if not elements:
                raise ValueError("PLY property declared before any element")
            if len(words) == 3 and words[1] in _PLY_TYPES:
                elements[-1].properties.append((words[2], words[1], None))
            elif (
                len(words) == 5
                and words[1] == "list"
                and words[2] in _PLY_INT_TYPES
                and words[3] in _PLY_TYPES
            ):
                elements[-1].properties.append((words[4], words[3], words[2]))
            else:
                raise ValueError(f"bad PLY property line {line[:60]!r}")
        else:
            raise ValueError(f"unknown PLY header line {line[:40]!r}")
    return encoding, elements, pos


def _check_ply_ascii_rows(text_rows: list[str], elements: list[PlyElement]) -> None:
    """Check the token count of every ASCII row whose layout is known from the header.

    Rows of elements made of scalars and at most one trailing list are checked: a row must
    have one token per scalar plus ``1 + n`` for a list of ``n`` items.  trimesh reads such
    elements as a rectangular table sized from the first row, so a row whose list length
    disagrees would be misread silently.
    """
    row = 0
    for element in elements:
        rows = text_rows[row : row + element.count]
        if len(rows) < element.count:
            raise ValueError(
                f"PLY element {element.name!r} declares {element.count} rows but only "
                f"{len(rows)} are present (truncated?)"
            )
        kinds = [count_type is not None for _, _, count_type in element.properties]
        if any(kinds[:-1]):
            row += element.count  # list before the end: layout unknown, trust the loader
            continue
        scalars = len(kinds) - (1 if kinds and kinds[-1] else 0)
        for i, text in enumerate(rows):
            tokens = text.split()
            expected = scalars
            if kinds and kinds[-1]:
                if len(tokens) <= scalars or not COUNT.fullmatch(tokens[scalars]):
                    expected = scalars + 1
                else:
                    expected = scalars + 1 + int(tokens[scalars])
            if len(tokens) != expected:
                raise ValueError(
                    f"PLY {element.name} row {i} has {len(tokens)} values, expected {expected}"
                )
        row += element.count


def precheck(data: bytes, max_faces: int) -> Declared:
    """Check the header and the size of the data section; what the loaded mesh must hold."""
    encoding, elements, start = parse_header(data)
    by_name = {e.name: e for e in elements}
    vertex = by_name.get("vertex")
    if vertex is None:
        raise ValueError("PLY header declares no vertex element")
    names = {name for name, _, _ in vertex.properties}
    if not {"x", "y", "z"} <= names:
        raise ValueError("PLY vertex element lacks x, y or z")
    face = by_name.get("face")
    n_faces = face.count if face is not None else 0
    if n_faces > max_faces:
        raise ValueError(f"PLY header declares {n_faces} faces, more than the limit of {max_faces}")
    if vertex.count > vertex_limit(max_faces):
        raise ValueError(
            f"PLY header declares {vertex.count} vertices, more than the limit of "
            f"{vertex_limit(max_faces)}"
        )
    # Lower bound on the size of the data section: lists may be empty.
    available = len(data) - start
    needed = 0
    for element in elements:
        if encoding == "ascii":
            per_row = 2 * len(element.properties)
        else:
            per_row = sum(
                _PLY_TYPES[count_type if count_type else kind]
                for _, kind, count_type in element.properties
            )
        needed += element.count * per_row
    if needed > available:
        raise ValueError(
            f"PLY header needs at least {needed} bytes of data but the file has {available} "
            "(truncated?)"
        )
    if encoding == "ascii":
        try:
            text = data[start:].decode("utf-8")
        except UnicodeDecodeError:
            raise ValueError("ASCII PLY data is not text (corrupt?)") from None
        _check_ply_ascii_rows(text.splitlines(), elements)
    return Declared(vertices=vertex.count, polygons=n_faces, check_list_counts=encoding != "ascii")


def _ply_list_counts_consistent(raw: dict) -> bool:
    """True if every list in the PLY data trimesh loaded has the length it assumed."""
    for element in raw.values():
        data = element.get("data") if isinstance(element, dict) else None
        if not isinstance(data, np.ndarray) or data.dtype.names is None:
            continue
        for name in data.dtype.names:
            column = data[name]
            if column.dtype.names == ("f0", "f1"):
                width = column["f1"].shape[1] if column["f1"].ndim == 2 else 1
                if np.any(column["f0"] != width):
                    return False
    return True


def check_loaded(scene: Any, declared: Declared) -> None:
    """Refuse a binary PLY whose lists trimesh read with a length they do not have.

    ``scene`` is the ``trimesh.Scene`` loaded from the file; ``declared`` what
    :func:`precheck` returned (``check_list_counts`` is set for binary files).
    """
    if declared.check_list_counts:
        for geometry in scene.geometry.values():
            raw = geometry.metadata.get("_ply_raw")
            if isinstance(raw, dict) and not _ply_list_counts_consistent(raw):
                raise MeshError("PLY lists have inconsistent lengths (corrupt face data?)")


_PLY_HEADER = (
    "ply\n"
    "format binary_little_endian 1.0\n"
    "element vertex {n_vertices}\n"
    "property double x\n"
    "property double y\n"
    "property double z\n"
    "element face {n_faces}\n"
    "property list uchar int vertex_indices\n"
    "end_header\n"
)
_PLY_FACE_DTYPE = np.dtype([("count", "<u1"), ("index", "<i4", (3,))])


def write(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """Binary little-endian PLY with float64 coordinates and int32 indices."""
    if len(vertices) > np.iinfo(np.int32).max:
        raise MeshError(f"PLY output holds at most 2**31 - 1 vertices, got {len(vertices)}")
    header = _PLY_HEADER.format(n_vertices=len(vertices), n_faces=len(faces))
    packed = np.empty(len(faces), dtype=_PLY_FACE_DTYPE)
    packed["count"] = 3
    packed["index"] = faces
    return header.encode("ascii") + vertices.astype("<f8").tobytes() + packed.tobytes()
