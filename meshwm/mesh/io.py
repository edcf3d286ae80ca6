"""Read and write triangle meshes (OBJ, PLY, STL, OFF, GLB) as ``(vertices, faces)`` arrays.

Reading goes through :mod:`trimesh` with ``process=False``, so vertices are neither merged nor
reordered; cleaning is the caller's job.  Every failure, whatever trimesh or NumPy raised, comes
out as a :class:`~meshwm._validate.MeshError` whose one-line message starts with the file name.
Before trimesh sees a file, a cheap check of its header (PLY, OFF, binary STL, GLB) or of its
face lines (OBJ, ASCII STL) refuses absurd element counts, counts the file is too short to hold
and a few defects trimesh would silently accept (OBJ index 0, short faces, inconsistent PLY
list lengths).

Writing serialises to bytes (PLY and OBJ by this module, float64-exact; STL by trimesh), then
replaces the target atomically.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import re
import struct
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from numpy.typing import NDArray

from meshwm._atomic import write_atomic
from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import MeshError

__all__ = [
    "READ_SUFFIXES",
    "WRITE_SUFFIXES",
    "check_output",
    "check_output_suffix",
    "read_mesh",
    "write_mesh",
]

PathLike = str | os.PathLike[str]

#: Longest exception text from a loader that is quoted in an error message.
_MAX_DETAIL = 160
#: A PLY header longer than this is refused (real headers are a few hundred bytes).
_MAX_PLY_HEADER = 1 << 20
#: Extra vertices allowed on top of three per face (unreferenced vertices).
_VERTEX_SLACK = 1024


# --------------------------------------------------------------------------------------------
# errors and small helpers
# --------------------------------------------------------------------------------------------


def _error(path: PathLike, detail: str) -> MeshError:
    """Build a one-line :class:`MeshError` ``"<path>: <detail>"``."""
    message = f"{os.fspath(path)}: {detail}"
    return MeshError(" ".join(message.splitlines()))


def _describe(exc: BaseException) -> str:
    """Short one-line ``"Type: message"`` description of an exception from a loader."""
    text = " ".join(str(exc).split())
    if len(text) > _MAX_DETAIL:
        text = text[: _MAX_DETAIL - 3] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _vertex_limit(max_faces: int) -> int:
    """Most vertices accepted for a file limited to ``max_faces`` faces."""
    return 3 * max_faces + _VERTEX_SLACK


@contextlib.contextmanager
def _quiet_trimesh() -> Iterator[None]:
    """Silence warnings and trimesh's log output while trimesh loads or exports.

    Malformed files make trimesh log at WARNING level (printed on stderr when no logging is
    configured) and make NumPy emit ``RuntimeWarning``/``DeprecationWarning``; the reader
    reports problems through :class:`MeshError` instead.  Not thread-safe: it changes the
    global warning filters and the level of the ``trimesh`` logger for its duration.
    """
    logger = logging.getLogger("trimesh")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            yield
    finally:
        logger.setLevel(level)


@dataclass(frozen=True)
class _Declared:
    """What a file's header (or a cheap scan of it) says the loaded mesh must contain.

    ``vertices``: exact vertex count, or None if unknown.  ``polygons``: the number of faces in
    the file; each yields at least one triangle (``exact_triangles``: exactly one).
    ``check_list_counts``: verify that every PLY list has the length trimesh assumed.
    ``text``: the data is text; invalid UTF-8 is replaced before trimesh decodes it (trimesh
    would otherwise need the optional ``charset_normalizer`` to guess an encoding).
    """

    vertices: int | None = None
    polygons: int | None = None
    exact_triangles: bool = False
    check_list_counts: bool = False
    text: bool = False


# --------------------------------------------------------------------------------------------
# pre-checks, one per format: cheap scans run before trimesh sees the bytes
# --------------------------------------------------------------------------------------------

_PLY_TYPES = {
    "char": 1, "uchar": 1, "short": 2, "ushort": 2, "int": 4, "uint": 4,
    "float": 4, "double": 8, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
    "int32": 4, "uint32": 4, "int64": 8, "uint64": 8, "float16": 2, "float32": 4,
    "float64": 8,
}  # fmt: skip
_PLY_INT_TYPES = {name for name in _PLY_TYPES if not name.startswith(("float", "double"))}
_PLY_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")
_COUNT = re.compile(r"\+?\d+")


@dataclass
class _PlyElement:
    name: str
    count: int
    #: (name, scalar type, list-count type or None)
    properties: list[tuple[str, str, str | None]] = field(default_factory=list)


def _parse_ply_header(data: bytes) -> tuple[str, list[_PlyElement], int]:
    """Strictly parse a PLY header; return (format, elements, offset of the data section)."""
    if not (data.startswith(b"ply\n") or data.startswith(b"ply\r\n")):
        raise ValueError("not a PLY file (the first line is not 'ply')")
    elements: list[_PlyElement] = []
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
            if len(words) != 3 or not _COUNT.fullmatch(words[2]):
                raise ValueError(f"bad PLY element line {line[:60]!r} (count must be >= 0)")
            if any(e.name == words[1] for e in elements):
                raise ValueError(f"PLY element {words[1][:20]!r} is declared twice")
            elements.append(_PlyElement(words[1], int(words[2])))
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


def _check_ply_ascii_rows(text_rows: list[str], elements: list[_PlyElement]) -> None:
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
                if len(tokens) <= scalars or not _COUNT.fullmatch(tokens[scalars]):
                    expected = scalars + 1
                else:
                    expected = scalars + 1 + int(tokens[scalars])
            if len(tokens) != expected:
                raise ValueError(
                    f"PLY {element.name} row {i} has {len(tokens)} values, expected {expected}"
                )
        row += element.count


def _precheck_ply(data: bytes, max_faces: int) -> _Declared:
    encoding, elements, start = _parse_ply_header(data)
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
    if vertex.count > _vertex_limit(max_faces):
        raise ValueError(
            f"PLY header declares {vertex.count} vertices, more than the limit of "
            f"{_vertex_limit(max_faces)}"
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
    return _Declared(vertices=vertex.count, polygons=n_faces, check_list_counts=encoding != "ascii")


_OFF_KEYWORD = re.compile(r"[A-Z0-9]*OFF")


def _precheck_off(data: bytes, max_faces: int) -> _Declared:
    head = data[: 1 << 16].decode("latin-1")
    tokens: list[str] = []
    for line in head.splitlines():
        tokens.extend(line.split("#", 1)[0].split())
        if len(tokens) >= 3:
            break
    if not tokens or not _OFF_KEYWORD.fullmatch(tokens[0]):
        first = tokens[0][:20] if tokens else ""
        raise ValueError(f"not an OFF file (first word {first!a}, expected 'OFF')")
    if len(tokens) < 3:
        raise ValueError("OFF header lacks the vertex and face counts (truncated?)")
    for token in tokens[1:3]:
        if not _COUNT.fullmatch(token):
            raise ValueError(f"OFF header counts must be integers >= 0, got {token[:20]!r}")
    n_vertices, n_faces = int(tokens[1]), int(tokens[2])
    if n_faces > max_faces:
        raise ValueError(f"OFF header declares {n_faces} faces, more than the limit of {max_faces}")
    if n_vertices > _vertex_limit(max_faces):
        raise ValueError(
            f"OFF header declares {n_vertices} vertices, more than the limit of "
            f"{_vertex_limit(max_faces)}"
        )
    # "x y z\n" takes at least 6 bytes and "3 a b c\n" at least 8.
    needed = 6 * n_vertices + 8 * n_faces - 1
    if needed > len(data):
        raise ValueError(
            f"OFF header declares {n_vertices} vertices and {n_faces} faces, which need at "
            f"least {needed} bytes, but the file has {len(data)} (truncated?)"
        )
    return _Declared(vertices=n_vertices, polygons=n_faces, text=True)


# Records trimesh skips silently: indented lines and a tab right after the keyword.
_OBJ_ODD_RECORD = re.compile(rb"\n[ \t]+[a-z]|\n(?:v|vt|vn|f)\t")
_OBJ_INDENT = re.compile(rb"^[ \t]+", re.MULTILINE)
_OBJ_KEYWORD_TAB = re.compile(rb"^(vn|vt|v|f)\t+", re.MULTILINE)
# Searched in b"\n" + data, so each pattern starts with a literal (fast scan).
_OBJ_SHORT_FACE = re.compile(rb"\nf(?:[ \t]+[^ \t\r\n]+){0,2}[ \t\r]*(?=\n|\Z)")
_OBJ_ZERO_INDEX = re.compile(rb"\nf[ \t][^\n]*?(?<=[ \t/])[+-]?0+(?=[/ \t\r\n]|\Z)")


def _prepare_obj(data: bytes) -> bytes:
    """Rewrite OBJ records trimesh would skip silently (indented, tab after the keyword)."""
    if _OBJ_ODD_RECORD.search(b"\n" + data) is None:
        return data
    return _OBJ_KEYWORD_TAB.sub(rb"\1 ", _OBJ_INDENT.sub(b"", data))


def _precheck_obj(data: bytes, max_faces: int) -> _Declared:
    scan = b"\n" + data
    n_faces = scan.count(b"\nf ")
    if n_faces > max_faces:
        raise ValueError(f"OBJ file has {n_faces} faces, more than the limit of {max_faces}")
    n_vertices = scan.count(b"\nv ")
    if n_vertices > _vertex_limit(max_faces):
        raise ValueError(
            f"OBJ file has {n_vertices} vertices, more than the limit of {_vertex_limit(max_faces)}"
        )
    short = _OBJ_SHORT_FACE.search(scan)
    if short is not None:
        line = scan.count(b"\n", 0, short.start() + 1)
        raise ValueError(f"OBJ face on line {line} has fewer than 3 vertices")
    zero = _OBJ_ZERO_INDEX.search(scan)
    if zero is not None:
        line = scan.count(b"\n", 0, zero.start() + 1)
        raise ValueError(f"OBJ face on line {line} uses index 0 (OBJ indices start at 1)")
    return _Declared(polygons=n_faces, text=True)


_STL_HEADER = 84
_STL_RECORD = 50


def _precheck_stl(data: bytes, max_faces: int) -> _Declared:
    if len(data) >= _STL_HEADER:
        (n_binary,) = struct.unpack_from("<I", data, 80)
        if len(data) == _STL_HEADER + _STL_RECORD * n_binary:
            # trimesh tries binary first and accepts it when the size matches exactly.
            if n_binary > max_faces:
                raise ValueError(
                    f"STL header declares {n_binary} triangles, more than the limit of {max_faces}"
                )
            return _Declared(polygons=n_binary, exact_triangles=True)
    else:
        n_binary = None
    if data.lstrip()[:5].lower() == b"solid":
        n_facets = data.lower().count(b"endfacet")
        if n_facets > max_faces:
            raise ValueError(f"STL file has {n_facets} facets, more than the limit of {max_faces}")
        return _Declared(polygons=n_facets, exact_triangles=True, text=True)
    if n_binary is None:
        raise ValueError(f"file of {len(data)} bytes is too short for a binary STL")
    raise ValueError(
        f"binary STL header declares {n_binary} triangles, which need "
        f"{_STL_HEADER + _STL_RECORD * n_binary} bytes, but the file has {len(data)} "
        "(truncated or not an STL file?)"
    )


def _precheck_glb(data: bytes, max_faces: int) -> _Declared:
    if len(data) < 20:
        raise ValueError(f"file of {len(data)} bytes is too short for a GLB file")
    magic, version, length, json_length, json_type = struct.unpack_from("<4sIIII", data)
    if magic != b"glTF":
        raise ValueError("not a GLB file (no 'glTF' magic)")
    if version != 2:
        raise ValueError(f"unsupported glTF version {version} (only 2 is supported)")
    if length > len(data):
        raise ValueError(
            f"GLB header declares {length} bytes but the file has {len(data)} (truncated?)"
        )
    if json_type != 0x4E4F534A or 20 + json_length > len(data):
        raise ValueError("GLB JSON chunk is missing or truncated")
    try:
        gltf = json.loads(data[20 : 20 + json_length])
    except (ValueError, RecursionError):
        raise ValueError("GLB JSON chunk is not valid JSON (corrupt?)") from None
    accessors = gltf.get("accessors", []) if isinstance(gltf, dict) else None
    if not isinstance(accessors, list):
        raise ValueError("GLB JSON has a malformed 'accessors' list")
    limit = _vertex_limit(max_faces)
    for i, accessor in enumerate(accessors):
        count = accessor.get("count") if isinstance(accessor, dict) else None
        if isinstance(count, bool) or not isinstance(count, int) or count < 0:
            raise ValueError(f"GLB accessor {i} has an invalid count")
        if count > limit:
            raise ValueError(
                f"GLB accessor {i} declares {count} elements, more than the limit of {limit}"
            )
    return _Declared()


@dataclass(frozen=True)
class _Reader:
    """How to read one suffix: trimesh file type, human name, pre-check, loader options.

    ``prepare`` (optional) rewrites the bytes before the pre-check and the loader.
    """

    file_type: str
    label: str
    precheck: Callable[[bytes, int], _Declared]
    options: dict[str, Any] = field(default_factory=dict)
    prepare: Callable[[bytes], bytes] | None = None


#: Registry of readable suffixes (lower case).
_READERS: dict[str, _Reader] = {
    ".obj": _Reader(
        "obj",
        "OBJ",
        _precheck_obj,
        {"maintain_order": True, "skip_materials": True},
        prepare=_prepare_obj,
    ),
    ".ply": _Reader("ply", "PLY", _precheck_ply, {"skip_materials": True}),
    ".stl": _Reader("stl", "STL", _precheck_stl),
    ".off": _Reader("off", "OFF", _precheck_off),
    ".glb": _Reader("glb", "GLB", _precheck_glb, {"skip_materials": True}),
}

#: Suffixes :func:`read_mesh` accepts.
READ_SUFFIXES: tuple[str, ...] = tuple(sorted(_READERS))


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------


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


def _load_with_trimesh(
    data: bytes, reader: _Reader, declared: _Declared
) -> tuple[NDArray, NDArray]:
    """Load ``data`` with trimesh and concatenate every mesh in the scene (transforms applied)."""
    if declared.text:
        data = data.decode("utf-8", errors="replace").encode("utf-8")
    scene = trimesh.load_scene(
        io.BytesIO(data), file_type=reader.file_type, process=False, **reader.options
    )
    if declared.check_list_counts:
        for geometry in scene.geometry.values():
            raw = geometry.metadata.get("_ply_raw")
            if isinstance(raw, dict) and not _ply_list_counts_consistent(raw):
                raise MeshError("PLY lists have inconsistent lengths (corrupt face data?)")
    vertex_parts: list[NDArray] = []
    face_parts: list[NDArray] = []
    offset = 0
    # What ``scene.dump()`` gives, without its copies and cache hashing (most of the time of
    # a read): each geometry instance with its node transform applied, the winding reversed
    # when the transform mirrors (as ``Trimesh.apply_transform`` does).
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        mesh = scene.geometry[name]
        if not isinstance(mesh, trimesh.Trimesh):
            continue
        vertices = np.asarray(mesh.vertices)
        faces = np.asarray(mesh.faces)
        if not np.array_equal(transform, np.eye(4)):
            vertices = trimesh.transformations.transform_points(vertices, transform)
            linear = transform[:3, :3]
            if not np.allclose(linear, np.eye(3), atol=1e-6) and (
                trimesh.transformations.flips_winding(transform)
            ):
                faces = faces[:, ::-1]
        if faces.size:
            if faces.ndim != 2 or faces.shape[1] != 3:
                raise MeshError(f"faces could not be triangulated (shape {faces.shape})")
            face_parts.append(faces.astype(np.int64) + offset)
        vertex_parts.append(vertices)
        offset += len(vertices)
    if not face_parts:
        raise MeshError("file contains no faces (empty, truncated or only points?)")
    return np.concatenate(vertex_parts), np.concatenate(face_parts)


def _reader_for(path: PathLike) -> _Reader:
    suffix = Path(path).suffix.lower()
    reader = _READERS.get(suffix)
    if reader is None:
        shown = f"unknown mesh file suffix {suffix!r}" if suffix else "file name has no suffix"
        raise _error(path, f"{shown}; valid suffixes are {', '.join(READ_SUFFIXES)}")
    return reader


def read_mesh(
    path: PathLike, *, max_faces: int = DEFAULT_MAX_FACES
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Read a triangle mesh file into vertex and face arrays.

    The format is chosen by the (case-insensitive) suffix: ``.obj``, ``.ply`` (ASCII or
    binary), ``.stl`` (ASCII or binary), ``.off`` or ``.glb``.  Polygons are triangulated.
    Vertices are returned as stored: not merged, not reordered, unreferenced ones kept
    (except where the format itself forces a layout, e.g. STL has three vertices per
    triangle, and OBJ corners with texture or normal indices are split per combination).
    The geometries of a GLB scene, or of an OBJ with several material groups, are
    concatenated with their scene transforms applied.

    Parameters
    ----------
    path : str or os.PathLike
        File to read.
    max_faces : int, optional
        Refuse files with more faces than this (default ``DEFAULT_MAX_FACES``).  Element
        counts in headers are checked before anything is loaded; more than
        ``3 * max_faces + 1024`` vertices are refused as well.

    Returns
    -------
    vertices : (n, 3) float64 ndarray
        Vertex positions, finite.
    faces : (m, 3) int64 ndarray
        Triangles as indices into ``vertices``, all in ``[0, n)``.

    Raises
    ------
    MeshError
        For any problem with the file: unknown suffix, missing, a directory, unreadable,
        empty, truncated or corrupt, absurd header counts, no faces, NaN or infinite
        coordinates, face indices out of range, more than ``max_faces`` faces.  The message
        is one line and starts with ``path``.
    TypeError, ValueError
        ``max_faces`` is not a positive integer.

    Notes
    -----
    The bytes are checked before trimesh parses them: PLY, OFF, binary STL and GLB header
    counts against the limits and against the size of the file, OBJ face lines for fewer
    than three vertices or index 0 (which trimesh would silently read as vertex 1).  After
    loading, the counts are compared with what the header declared, so faces trimesh drops
    silently are reported.  Warnings and trimesh log output raised while loading are
    suppressed (not thread-safe: the warning filters and the ``trimesh`` logger level are
    process-global).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from meshwm.mesh.io import read_mesh, write_mesh
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.1, 0.0]])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     write_mesh(os.path.join(tmp, "tri.obj"), v, [[0, 1, 2]])
    ...     vertices, faces = read_mesh(os.path.join(tmp, "tri.obj"))
    >>> bool(np.array_equal(vertices, v)), faces.tolist()
    (True, [[0, 1, 2]])
    """
    if isinstance(max_faces, bool) or not isinstance(max_faces, (int, np.integer)):
        raise TypeError(f"max_faces must be an integer, got {type(max_faces).__name__}")
    max_faces = int(max_faces)
    if max_faces < 1:
        raise ValueError(f"max_faces must be at least 1, got {max_faces}")

    reader = _reader_for(path)
    if not os.path.lexists(path):
        raise _error(path, "no such file")
    if os.path.isdir(path):
        raise _error(path, "is a directory, not a mesh file")
    try:
        with open(path, "rb") as stream:
            data = stream.read()
    except OSError as exc:
        raise _error(path, f"cannot read file ({exc.strerror or _describe(exc)})") from exc
    if not data:
        raise _error(path, "file is empty (0 bytes)")

    if reader.prepare is not None:
        data = reader.prepare(data)
    try:
        declared = reader.precheck(data, max_faces)
    except ValueError as exc:
        raise _error(path, str(exc)) from None

    try:
        with _quiet_trimesh():
            vertices, faces = _load_with_trimesh(data, reader, declared)
    except MeshError as exc:
        raise _error(path, str(exc)) from None
    except Exception as exc:  # trimesh and NumPy raise anything on malformed input
        raise _error(
            path, f"cannot read {reader.label} file, truncated or corrupt? ({_describe(exc)})"
        ) from exc

    if declared.vertices is not None and len(vertices) != declared.vertices:
        raise _error(
            path,
            f"read {len(vertices)} vertices but the header declares {declared.vertices} "
            "(corrupt file?)",
        )
    if declared.polygons is not None:
        fewer = len(faces) < declared.polygons
        if fewer or (declared.exact_triangles and len(faces) != declared.polygons):
            raise _error(
                path,
                f"read {len(faces)} triangles from {declared.polygons} declared faces "
                "(malformed faces?)",
            )
    if len(vertices) > _vertex_limit(max_faces):
        raise _error(
            path,
            f"mesh has {len(vertices)} vertices, more than the limit of {_vertex_limit(max_faces)}",
        )
    try:
        return check_mesh(vertices, faces, max_faces=max_faces)
    except MeshError as exc:
        raise _error(path, str(exc)) from None


# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------

_PLY_HEADER = (
    "ply\n"
    "format binary_little_endian 1.0\n"
    "comment written by meshwm\n"
    "element vertex {n_vertices}\n"
    "property double x\n"
    "property double y\n"
    "property double z\n"
    "element face {n_faces}\n"
    "property list uchar int vertex_indices\n"
    "end_header\n"
)
_PLY_FACE_DTYPE = np.dtype([("count", "<u1"), ("index", "<i4", (3,))])


def _ply_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """Binary little-endian PLY with float64 coordinates and int32 indices."""
    if len(vertices) > np.iinfo(np.int32).max:
        raise MeshError(f"PLY output holds at most 2**31 - 1 vertices, got {len(vertices)}")
    header = _PLY_HEADER.format(n_vertices=len(vertices), n_faces=len(faces))
    packed = np.empty(len(faces), dtype=_PLY_FACE_DTYPE)
    packed["count"] = 3
    packed["index"] = faces
    return header.encode("ascii") + vertices.astype("<f8").tobytes() + packed.tobytes()


def _obj_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """OBJ text with each coordinate written as Python's shortest round-trip ``repr``."""
    vertex_text = ("v {!r} {!r} {!r}\n" * len(vertices)).format(*vertices.ravel().tolist())
    face_text = ("f {} {} {}\n" * len(faces)).format(*(faces + 1).ravel().tolist())
    return ("# written by meshwm\n" + vertex_text + face_text).encode("ascii")


def _stl_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """Binary STL written by trimesh (float32 coordinates, zeroed 80-byte header)."""
    with _quiet_trimesh():
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        return bytes(mesh.export(file_type="stl"))


#: Registry of writable suffixes (lower case) -> serialiser.
_WRITERS: dict[str, Callable[[NDArray[np.float64], NDArray[np.int64]], bytes]] = {
    ".obj": _obj_bytes,
    ".ply": _ply_bytes,
    ".stl": _stl_bytes,
}

#: Suffixes :func:`write_mesh` accepts.
WRITE_SUFFIXES: tuple[str, ...] = tuple(sorted(_WRITERS))


def check_output_suffix(path: PathLike) -> None:
    """Raise early if ``path`` has a suffix :func:`write_mesh` cannot write.

    Parameters
    ----------
    path : str or os.PathLike
        Intended output file.

    Raises
    ------
    MeshError
        The (case-insensitive) suffix is not one of ``WRITE_SUFFIXES``; the message lists
        the valid ones.

    Examples
    --------
    >>> check_output_suffix("out.PLY")
    >>> check_output_suffix("out.glb")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    meshwm._validate.MeshError: out.glb: cannot write '.glb' files; valid output suffixes are ...
    """
    suffix = Path(path).suffix.lower()
    if suffix not in _WRITERS:
        what = f"{suffix!r} files" if suffix else "files without a suffix"
        valid = ", ".join(WRITE_SUFFIXES)
        raise _error(path, f"cannot write {what}; valid output suffixes are {valid}")


def check_output(
    path: PathLike, *, overwrite_input: PathLike | None = None, force: bool = False
) -> None:
    """Raise early if :func:`write_mesh` would refuse to write ``path``.

    Checks the suffix (:func:`check_output_suffix`) and, unless ``force``, that ``path`` is not
    the same file as ``overwrite_input`` (:func:`os.path.samefile`, so links and relative paths
    count).  The CLI calls it before any expensive work; :func:`write_mesh` calls it again.

    Raises
    ------
    MeshError
        Unsupported suffix, or the output would overwrite the input.
    """
    check_output_suffix(path)
    parent = Path(path).resolve().parent
    if not parent.is_dir():
        raise _error(path, f"folder {parent} does not exist")
    if (
        overwrite_input is not None
        and not force
        and os.path.exists(path)
        and os.path.exists(overwrite_input)
        and os.path.samefile(path, overwrite_input)
    ):
        raise _error(path, "would overwrite the input; use --force")


def write_mesh(
    path: PathLike,
    vertices: NDArray,
    faces: NDArray,
    *,
    overwrite_input: PathLike | None = None,
    force: bool = False,
) -> None:
    """Write a triangle mesh to an OBJ, PLY or STL file, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; the (case-insensitive) suffix picks the format: ``.ply`` (binary
        little-endian, float64 coordinates), ``.obj`` (text, every coordinate written with
        the shortest representation that reads back exactly) or ``.stl`` (binary).
    vertices : (n, 3) array_like of float
        Vertex positions; must be finite.
    faces : (m, 3) array_like of int
        Triangles as indices into ``vertices``.
    overwrite_input : str or os.PathLike, optional
        The file the mesh was read from.  If ``path`` is that same file (checked with
        :func:`os.path.samefile`, so links and relative paths count), writing is refused
        unless ``force`` is true.
    force : bool, optional
        Allow overwriting ``overwrite_input``.

    Raises
    ------
    MeshError
        Unknown suffix, invalid arrays (see :func:`~meshwm._validate.check_mesh`), ``path``
        is ``overwrite_input`` without ``force``, or the file cannot be written.  The
        message is one line and starts with ``path``.

    Notes
    -----
    The bytes are written to a temporary file in the target's directory, flushed and
    fsynced, then moved onto ``path`` with :func:`os.replace`; on any failure the temporary
    file is removed and ``path`` is left as it was.  Output is byte-for-byte deterministic
    for the same arrays (no timestamps).  PLY and OBJ round-trip float64 exactly through
    :func:`read_mesh`.  STL stores float32 coordinates, one vertex triple per triangle, so
    reading it back gives rounded, un-indexed vertices.  A new file gets the usual
    permissions (``0o666`` minus the umask); an overwritten one keeps its permissions.
    """
    check_output(path, overwrite_input=overwrite_input, force=force)
    try:
        vertices, faces = check_mesh(vertices, faces, max_faces=np.iinfo(np.int64).max)
    except MeshError as exc:
        raise _error(path, f"cannot write: {exc}") from None

    try:
        payload = _WRITERS[Path(path).suffix.lower()](vertices, faces)
    except MeshError as exc:
        raise _error(path, str(exc)) from None

    try:
        write_atomic(path, payload)
    except OSError as exc:
        raise _error(path, f"cannot write file ({exc.strerror or _describe(exc)})") from exc
