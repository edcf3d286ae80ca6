"""Generator of malformed mesh files for the reader tests (``tests/mesh/io/test_read.py``).

Every case is built deterministically from the binary PLY assets in ``assets/`` (parsed here
with NumPy, independently of :mod:`meshwm.mesh.io`) or from generated text: truncations, byte
flips at fixed structural offsets or at positions derived with :mod:`hashlib`, absurd header
counts, NaN/inf coordinates, face indices out of range, empty and non-mesh files.  Corruptions
are chosen so that they always break something a careful reader can detect (a header keyword,
a list count, an index high byte); flips inside float values would give a valid mesh and are
not used.  A plain truncation of an OBJ file at a line boundary is a valid, smaller OBJ (the
format has no counts), so OBJ truncations cut inside a face line.

Cases with ``must_fail_on_read=False`` (a single triangle, a non-manifold fan, a degenerate
triangle) are readable; later stages reject them.

Usage::

    cases = make_malformed_cases(tmp_dir)  # list of MalformedCase(case_id, path, must_fail)

``CASE_IDS`` lists the ids statically, in the order :func:`make_malformed_cases` returns them,
so tests can be parametrized at collection time.
"""

from __future__ import annotations

import hashlib
import io
import json
import struct
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import NamedTuple

import numpy as np
import trimesh

__all__ = [
    "CASE_IDS",
    "MUST_FAIL_ON_READ_IDS",
    "MalformedCase",
    "make_malformed_cases",
]

ASSETS = Path(__file__).parent.parent / "assets"


class MalformedCase(NamedTuple):
    """One generated file: its id, its path and whether :func:`read_mesh` must refuse it."""

    case_id: str
    path: Path
    must_fail_on_read: bool


# --------------------------------------------------------------------------------------------
# sources
# --------------------------------------------------------------------------------------------


class _BinaryPly(NamedTuple):
    data: bytes
    header_length: int
    vertices: np.ndarray
    faces: np.ndarray

    @property
    def vertex_block(self) -> int:
        return self.header_length

    @property
    def face_block(self) -> int:
        return self.header_length + 24 * len(self.vertices)


@cache
def _asset(name: str) -> _BinaryPly:
    """Parse one of the asset PLYs (binary LE, double xyz, ``list uchar int`` faces)."""
    data = (ASSETS / name).read_bytes()
    header_length = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:header_length].decode("ascii").split("\n")
    n_vertices = int(next(w.split()[2] for w in header if w.startswith("element vertex")))
    n_faces = int(next(w.split()[2] for w in header if w.startswith("element face")))
    vertices = np.frombuffer(data, "<f8", 3 * n_vertices, header_length).reshape(-1, 3)
    face_dtype = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
    faces = np.frombuffer(data, face_dtype, n_faces, header_length + vertices.nbytes)
    assert (faces["n"] == 3).all() and header_length + vertices.nbytes + faces.nbytes == len(data)
    return _BinaryPly(data, header_length, vertices, faces["i"].astype(np.int64))


def _spot() -> _BinaryPly:
    return _asset("spot.ply")


def _hash_ints(label: str, count: int, modulo: int) -> list[int]:
    """``count`` deterministic pseudo-random integers in ``[0, modulo)`` derived from sha256."""
    out = []
    for i in range(count):
        digest = hashlib.sha256(f"meshwm-malformed:{label}:{i}".encode()).digest()
        out.append(int.from_bytes(digest[:8], "little") % modulo)
    return out


def _hash_bytes(label: str, size: int) -> bytes:
    """``size`` deterministic pseudo-random bytes (sha256 in counter mode)."""
    blocks = [
        hashlib.sha256(f"meshwm-random:{label}:{i}".encode()).digest()
        for i in range((size + 31) // 32)
    ]
    return b"".join(blocks)[:size]


# text exports of spot ---------------------------------------------------------------------


@cache
def _ply_ascii_text() -> str:
    mesh = _spot()
    header = (
        "ply\nformat ascii 1.0\n"
        f"element vertex {len(mesh.vertices)}\n"
        "property double x\nproperty double y\nproperty double z\n"
        f"element face {len(mesh.faces)}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    vertices = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in mesh.vertices.tolist())
    faces = "".join(f"3 {a} {b} {c}\n" for a, b, c in mesh.faces.tolist())
    return header + vertices + faces


@cache
def _obj_text() -> str:
    mesh = _spot()
    vertices = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in mesh.vertices.tolist())
    faces = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in mesh.faces.tolist())
    return "# spot\n" + vertices + faces


@cache
def _off_text() -> str:
    mesh = _spot()
    vertices = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in mesh.vertices.tolist())
    faces = "".join(f"3 {a} {b} {c}\n" for a, b, c in mesh.faces.tolist())
    return f"OFF\n{len(mesh.vertices)} {len(mesh.faces)} 0\n" + vertices + faces


@cache
def _stl_ascii_text() -> str:
    mesh = _spot()
    parts = ["solid spot\n"]
    for triangle in mesh.vertices[mesh.faces[:600]].tolist():
        parts.append("facet normal 0 0 0\nouter loop\n")
        parts.extend(f"vertex {x!r} {y!r} {z!r}\n" for x, y, z in triangle)
        parts.append("endloop\nendfacet\n")
    parts.append("endsolid spot\n")
    return "".join(parts)


@cache
def _stl_binary() -> bytes:
    mesh = _spot()
    records = np.zeros(len(mesh.faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    records["v"] = mesh.vertices[mesh.faces]
    return b"\0" * 80 + struct.pack("<I", len(records)) + records.tobytes()


@cache
def _glb() -> bytes:
    mesh = _spot()
    return bytes(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(file_type="glb"))


def _glb_parts(data: bytes) -> tuple[dict, bytes]:
    (json_length,) = struct.unpack_from("<I", data, 12)
    gltf = json.loads(data[20 : 20 + json_length])
    rest = data[20 + json_length :]
    return gltf, rest


def _glb_build(gltf: dict, rest: bytes) -> bytes:
    text = json.dumps(gltf).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + rest
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


# --------------------------------------------------------------------------------------------
# editing helpers
# --------------------------------------------------------------------------------------------


def _replace_once(data: bytes, old: bytes, new: bytes) -> bytes:
    assert data.count(old) >= 1, old
    return data.replace(old, new, 1)


def _set_bytes(data: bytes, offset: int, new: bytes) -> bytes:
    assert 0 <= offset and offset + len(new) <= len(data)
    return data[:offset] + new + data[offset + len(new) :]


def _replace_line(text: str, index: int, new: str) -> str:
    """Replace line ``index`` (0-based) of ``text``."""
    lines = text.split("\n")
    lines[index] = new
    return "\n".join(lines)


def _first_line_index(text: str, prefix: str) -> int:
    return next(i for i, line in enumerate(text.split("\n")) if line.startswith(prefix))


def _cut_inside_face_line(text: str, face_number: int, prefix: str) -> str:
    """Cut ``text`` right after the second index of face line ``face_number``."""
    lines = text.split("\n")
    first = _first_line_index(text, prefix)
    line = lines[first + face_number]
    head = " ".join(line.split()[:3]) + " "  # "f a b " or "3 a b "
    return "\n".join([*lines[: first + face_number], head])


# --------------------------------------------------------------------------------------------
# registry of cases
# --------------------------------------------------------------------------------------------

#: id -> (file name, builder returning the bytes or None for "do not create", must fail on read)
_CASES: dict[str, tuple[str, Callable[[], bytes | None], bool]] = {}


def _add(
    case_id: str, file_name: str, builder: Callable[[], bytes | None], must_fail: bool = True
) -> None:
    """Register a case; ``builder`` is called by :func:`make_malformed_cases`."""
    assert case_id not in _CASES, case_id
    _CASES[case_id] = (file_name, builder, must_fail)


# binary PLY truncations ---------------------------------------------------------------------

_PLY_TRUNCATIONS: dict[str, Callable[[_BinaryPly], int]] = {
    "header_magic": lambda m: 2,
    "header_format_line": lambda m: 10,
    "header_middle": lambda m: m.header_length // 2,
    "header_before_end": lambda m: m.header_length - 4,
    "vertex_first_value": lambda m: m.vertex_block + 5,
    "vertex_middle": lambda m: m.vertex_block + 24 * (len(m.vertices) // 2) + 11,
    "vertex_block_end": lambda m: m.face_block,
    "face_first_record": lambda m: m.face_block + 7,
    "face_middle": lambda m: m.face_block + 13 * (len(m.faces) // 2),
    "face_last_byte": lambda m: len(m.data) - 1,
}
for _label, _offset in _PLY_TRUNCATIONS.items():
    _add(
        f"ply_bin_truncated_{_label}",
        f"trunc_{_label}.ply",
        lambda o=_offset: _spot().data[: o(_spot())],
    )
for _asset_name in ("kitten", "plane_holes"):
    _add(
        f"ply_bin_{_asset_name}_truncated_face_middle",
        f"{_asset_name}_trunc.ply",
        lambda a=_asset_name: (lambda m: m.data[: m.face_block + 13 * 1000 + 6])(
            _asset(f"{a}.ply")
        ),
    )
_add(
    "ply_bin_header_only",
    "header_only_bin.ply",
    lambda: _spot().data[: _spot().header_length],
)
_add("ply_bin_trailing_garbage", "trailing.ply", lambda: _spot().data + b"\0\1\2\3\4\5\6")

# binary PLY header flips ----------------------------------------------------------------------


def _add_header_edits(case_prefix: str, file_prefix: str, edits: dict) -> None:
    """One case per edit: the spot PLY with one header string replaced."""
    for label, (old, new) in edits.items():
        _add(
            f"{case_prefix}_{label}",
            f"{file_prefix}_{label}.ply",
            lambda o=old, n=new: _replace_once(_spot().data, o, n),
        )


_HEADER_EDITS = {
    "magic": (b"ply\n", b"plz\n"),
    "format_keyword": (b"format ", b"formas "),
    "format_encoding": (b"binary_little_endian", b"binary_little_endiao"),
    "format_version": (b" 1.0\n", b" 1.1\n"),
    "comment_keyword": (b"comment", b"commenu"),
    "element_keyword": (b"element vertex", b"elemenu vertex"),
    "vertex_element_name": (b"element vertex", b"element vertey"),
    "property_type": (b"property double x", b"property doublf x"),
    "property_name": (b"property double x", b"property double w"),
    "face_element_name": (b"element face", b"element fade"),
    "list_count_type": (b"list uchar int", b"list uchaq int"),
    "end_header": (b"end_header", b"end_headeR"),
    "vertex_count_plus_one": (b"element vertex 2930", b"element vertex 2931"),
    "vertex_count_minus_ten": (b"element vertex 2930", b"element vertex 2920"),
    "face_count_plus_one": (b"element face 5856", b"element face 5857"),
}
_add_header_edits("ply_bin_header_flip", "hflip", _HEADER_EDITS)

# binary PLY face-block flips ------------------------------------------------------------------


def _face_count_byte(mesh: _BinaryPly, face: int) -> int:
    return mesh.face_block + 13 * face


def _face_index_high_byte(mesh: _BinaryPly, face: int, corner: int) -> int:
    return mesh.face_block + 13 * face + 1 + 4 * corner + 3


_FACE_EDITS: dict[str, tuple[str, Callable[[_BinaryPly], int], bytes]] = {
    "first_count_3_to_4": ("spot.ply", lambda m: _face_count_byte(m, 0), b"\x04"),
    "count_3_to_4_face_100": ("spot.ply", lambda m: _face_count_byte(m, 100), b"\x04"),
    "count_3_to_0_last_face": (
        "spot.ply",
        lambda m: _face_count_byte(m, len(m.faces) - 1),
        b"\x00",
    ),
    "count_3_to_5_kitten_1000": ("kitten.ply", lambda m: _face_count_byte(m, 1000), b"\x05"),
    "index_high_0x7f": ("spot.ply", lambda m: _face_index_high_byte(m, 50, 1), b"\x7f"),
    "index_high_0x80_negative": ("spot.ply", lambda m: _face_index_high_byte(m, 51, 0), b"\x80"),
    "index_high_last_face": (
        "spot.ply",
        lambda m: _face_index_high_byte(m, len(m.faces) - 1, 2),
        b"\x40",
    ),
    "index_high_plane_holes": (
        "plane_holes.ply",
        lambda m: _face_index_high_byte(m, 7000, 0),
        b"\x01",
    ),
}
for _label, (_name, _where, _byte) in _FACE_EDITS.items():
    _add(
        f"ply_bin_face_flip_{_label}",
        f"fflip_{_label}.ply",
        lambda n=_name, w=_where, b=_byte: (lambda m: _set_bytes(m.data, w(m), b))(_asset(n)),
    )
# hashlib-derived face / corner positions; the high byte always makes the index >= 2**24
for _i, _face in enumerate(_hash_ints("spot-face-flip", 3, 5856)):
    _corner = _hash_ints("spot-corner", 3, 3)[_i]
    _add(
        f"ply_bin_face_flip_hashed_{_i}",
        f"fflip_hashed_{_i}.ply",
        lambda f=_face, c=_corner, i=_i: _set_bytes(
            _spot().data, _face_index_high_byte(_spot(), f, c), bytes([0x01 + 0x31 * i])
        ),
    )
_add(
    "ply_bin_vertex_nan",
    "vertex_nan.ply",
    lambda: _set_bytes(_spot().data, _spot().vertex_block + 24 * 10, struct.pack("<d", np.nan)),
)
_add(
    "ply_bin_vertex_inf",
    "vertex_inf.ply",
    lambda: _set_bytes(
        _spot().data, _spot().vertex_block + 24 * 77 + 16, struct.pack("<d", -np.inf)
    ),
)

# binary PLY absurd counts ---------------------------------------------------------------------


def _ply_bin_huge_list_length() -> bytes:
    """Three vertices and one face whose ``uint`` list length is 2**31 - 1."""
    header = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
        b"property float y\nproperty float z\nelement face 1\n"
        b"property list uint int vertex_indices\nend_header\n"
    )
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()
    face = struct.pack("<I3i", 2**31 - 1, 0, 1, 2)
    return header + vertices + face


_add("ply_bin_list_length_huge", "list_length_huge.ply", _ply_bin_huge_list_length)

_COUNT_EDITS = {
    "vertex_huge": (b"element vertex 2930", b"element vertex 99999999999"),
    "face_huge": (b"element face 5856", b"element face 4000000000"),
    "face_over_limit_not_in_file": (b"element face 5856", b"element face 60000"),
    "vertex_negative": (b"element vertex 2930", b"element vertex -2930"),
    "face_non_numeric": (b"element face 5856", b"element face lots"),
}
_add_header_edits("ply_bin_count", "count", _COUNT_EDITS)

# ASCII PLY ------------------------------------------------------------------------------------


def _ply_ascii_first_face_line() -> int:
    return _first_line_index(_ply_ascii_text(), "end_header") + 1 + len(_spot().vertices)


def _ply_ascii_vertex_line(k: int) -> int:
    return _first_line_index(_ply_ascii_text(), "end_header") + 1 + k


_ASCII_PLY_EDITS: dict[str, Callable[[], str]] = {
    "truncated_header": lambda: _ply_ascii_text()[:60],
    "truncated_vertex_lines": lambda: (
        "\n".join(_ply_ascii_text().split("\n")[: _ply_ascii_vertex_line(1000)]) + "\n"
    ),
    "truncated_mid_vertex_line": lambda: _ply_ascii_text()[
        : _ply_ascii_text().index("\n", 2000) + 9
    ],
    "truncated_face_lines": lambda: (
        "\n".join(_ply_ascii_text().split("\n")[: _ply_ascii_first_face_line() + 3000]) + "\n"
    ),
    "vertex_nan": lambda: _replace_line(_ply_ascii_text(), _ply_ascii_vertex_line(5), "nan 0 0"),
    "vertex_inf": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_vertex_line(6), "0.5 inf 0.25"
    ),
    "vertex_non_numeric": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_vertex_line(7), "0.5 abc 0.25"
    ),
    "vertex_two_values": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_vertex_line(8), "0.5 0.25"
    ),
    "face_index_out_of_range": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_first_face_line() + 10, "3 0 1 99999"
    ),
    "face_index_negative": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_first_face_line() + 11, "3 0 -1 2"
    ),
    "face_count_mismatch": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_first_face_line() + 12, "4 0 1 2"
    ),
    "face_two_indices": lambda: _replace_line(
        _ply_ascii_text(), _ply_ascii_first_face_line() + 13, "2 0 1"
    ),
    "count_vertex_huge": lambda: _ply_ascii_text().replace(
        "element vertex 2930", "element vertex 99999999999"
    ),
    "count_face_huge": lambda: _ply_ascii_text().replace(
        "element face 5856", "element face 4000000000"
    ),
    "count_vertex_negative": lambda: _ply_ascii_text().replace(
        "element vertex 2930", "element vertex -3"
    ),
    "count_face_non_numeric": lambda: _ply_ascii_text().replace(
        "element face 5856", "element face 12x"
    ),
    "header_only": lambda: _ply_ascii_text()[: _ply_ascii_text().index("end_header\n") + 11],
    "vertices_no_face_element": lambda: (
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    ),
    "zero_faces": lambda: (
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 0\nproperty list uchar int vertex_indices\n"
        "end_header\n0 0 0\n1 0 0\n0 1 0\n"
    ),
}
for _label, _make in _ASCII_PLY_EDITS.items():
    _add(f"ply_ascii_{_label}", f"ascii_{_label}.ply", lambda m=_make: m().encode())

# OBJ ------------------------------------------------------------------------------------------


def _obj_first_face() -> int:
    return _first_line_index(_obj_text(), "f ")


_OBJ_EDITS: dict[str, Callable[[], str]] = {
    "truncated_in_vertices": lambda: _obj_text()[: len(_obj_text()) // 4],
    "truncated_inside_face_line": lambda: _cut_inside_face_line(_obj_text(), 2000, "f "),
    "vertex_nan": lambda: _replace_line(_obj_text(), 3, "v nan 0 0"),
    "vertex_inf": lambda: _replace_line(_obj_text(), 4, "v 0.5 inf 0.25"),
    "vertex_negative_inf": lambda: _replace_line(_obj_text(), 5, "v 0.5 0.25 -inf"),
    "vertex_two_coordinates": lambda: _replace_line(_obj_text(), 6, "v 0.5 0.25"),
    "face_index_out_of_range": lambda: _replace_line(
        _obj_text(), _obj_first_face() + 10, "f 1 2 99999"
    ),
    "face_index_negative_out_of_range": lambda: _replace_line(
        _obj_text(), _obj_first_face() + 11, "f -99999 1 2"
    ),
    "face_index_zero": lambda: _replace_line(_obj_text(), _obj_first_face() + 12, "f 0 1 2"),
    "face_index_zero_with_slashes": lambda: _replace_line(
        _obj_text(), _obj_first_face() + 12, "f 3//1 0//1 2//1"
    ),
    "face_two_vertices": lambda: _replace_line(_obj_text(), _obj_first_face() + 13, "f 1 2"),
    "face_non_numeric": lambda: _replace_line(_obj_text(), _obj_first_face() + 14, "f 1 x 3"),
    "only_vertices": lambda: _obj_text()[: _obj_text().index("\nf ") + 1],
    "no_vertices": lambda: "f 1 2 3\nf 2 3 4\n",
}
for _label, _make in _OBJ_EDITS.items():
    _add(f"obj_{_label}", f"{_label}.obj", lambda m=_make: m().encode())

# OFF ------------------------------------------------------------------------------------------


def _off_first_face() -> int:
    return 2 + len(_spot().vertices)


_OFF_EDITS: dict[str, Callable[[], str]] = {
    "truncated_in_vertices": lambda: _off_text()[: len(_off_text()) // 5],
    "truncated_in_faces": lambda: (
        "\n".join(_off_text().split("\n")[: _off_first_face() + 4000]) + "\n"
    ),
    "truncated_inside_face_line": lambda: _cut_inside_face_line(_off_text(), 100, "3 "),
    "count_vertex_huge": lambda: _off_text().replace("OFF\n2930 ", "OFF\n99999999999 "),
    "count_face_huge": lambda: _off_text().replace(" 5856 0\n", " 4000000000 0\n"),
    "count_negative": lambda: _off_text().replace("OFF\n2930 ", "OFF\n-5 "),
    "count_non_numeric": lambda: _off_text().replace("OFF\n2930 ", "OFF\nabc "),
    "bad_keyword": lambda: "OFX" + _off_text()[3:],
    "face_index_out_of_range": lambda: _replace_line(
        _off_text(), _off_first_face() + 5, "3 0 1 99999"
    ),
    "face_index_negative": lambda: _replace_line(_off_text(), _off_first_face() + 6, "3 -1 0 1"),
    "face_two_vertices": lambda: _replace_line(_off_text(), _off_first_face() + 7, "2 0 1"),
    "vertex_nan": lambda: _replace_line(_off_text(), 2, "nan 0 0"),
    "header_only": lambda: "OFF\n0 0 0\n",
}
for _label, _make in _OFF_EDITS.items():
    _add(f"off_{_label}", f"{_label}.off", lambda m=_make: m().encode())

# STL ------------------------------------------------------------------------------------------

_STL_EDITS: dict[str, Callable[[], bytes]] = {
    "binary_truncated": lambda: _stl_binary()[: 84 + 50 * 100 + 17],
    "binary_count_exceeds_file": lambda: _set_bytes(
        _stl_binary(), 80, struct.pack("<I", 5856 + 10)
    ),
    "binary_count_huge": lambda: _set_bytes(_stl_binary(), 80, struct.pack("<I", 0xFFFFFFFF)),
    "binary_header_only": lambda: b"\0" * 80 + struct.pack("<I", 0),
    "binary_short": lambda: b"\0" * 50,
    "binary_nan": lambda: _set_bytes(_stl_binary(), 84 + 50 * 3 + 12, struct.pack("<f", np.nan)),
    "ascii_truncated": lambda: _stl_ascii_text()[: len(_stl_ascii_text()) // 2].encode(),
    "ascii_non_numeric": lambda: _stl_ascii_text().replace("vertex ", "vertex q", 1).encode(),
    "ascii_no_facets": lambda: b"solid empty\nendsolid empty\n",
}
for _label, _make in _STL_EDITS.items():
    _add(f"stl_{_label}", f"{_label}.stl", _make)


def _stl_ascii_nan() -> bytes:
    text = _stl_ascii_text()
    first = text.index("vertex ") + len("vertex ")
    end = text.index(" ", first)
    return (text[:first] + "nan" + text[end:]).encode()


def _stl_ascii_two_vertices() -> bytes:
    lines = _stl_ascii_text().split("\n")
    k = next(i for i, line in enumerate(lines) if line.startswith("vertex"))
    del lines[k + 3 * 40]  # one vertex of facet 40
    return "\n".join(lines).encode()


_add("stl_ascii_vertex_nan", "ascii_vertex_nan.stl", _stl_ascii_nan)
_add("stl_ascii_two_vertex_facet", "ascii_two_vertex_facet.stl", _stl_ascii_two_vertices)

# GLB ------------------------------------------------------------------------------------------


def _glb_huge_accessor() -> bytes:
    gltf, rest = _glb_parts(_glb())
    gltf["accessors"][0]["count"] = 99_999_999_999
    return _glb_build(gltf, rest)


def _glb_bufferless_accessor() -> bytes:
    gltf, rest = _glb_parts(_glb())
    del gltf["accessors"][1]["bufferView"]
    gltf["accessors"][1]["count"] = 4_000_000_000
    return _glb_build(gltf, rest)


def _glb_index_out_of_range() -> bytes:
    gltf, rest = _glb_parts(_glb())
    accessor = gltf["accessors"][0]
    assert accessor["componentType"] == 5125  # uint32 indices
    view = gltf["bufferViews"][accessor["bufferView"]]
    start = 8 + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)  # BIN chunk header
    rest = _set_bytes(rest, start + 4 * 30, struct.pack("<I", 0x7FFF0000))
    return _glb_build(gltf, rest)


_GLB_EDITS: dict[str, Callable[[], bytes]] = {
    "truncated": lambda: _glb()[: len(_glb()) // 2],
    "truncated_json": lambda: _glb()[:40],
    "bad_magic": lambda: b"glTX" + _glb()[4:],
    "bad_version": lambda: _set_bytes(_glb(), 4, struct.pack("<I", 7)),
    "corrupt_json": lambda: _set_bytes(_glb(), 20, b"["),
    "accessor_count_huge": _glb_huge_accessor,
    "bufferless_accessor_huge": _glb_bufferless_accessor,
    "index_out_of_range": _glb_index_out_of_range,
}
for _label, _make in _GLB_EDITS.items():
    _add(f"glb_{_label}", f"{_label}.glb", _make)

# not meshes at all ----------------------------------------------------------------------------

for _suffix in (".ply", ".obj", ".stl", ".off", ".glb"):
    _add(f"empty{_suffix.replace('.', '_')}", f"empty{_suffix}", lambda: b"")
for _suffix in (".ply", ".obj", ".stl", ".off", ".glb"):
    _add(
        f"random_bytes{_suffix.replace('.', '_')}",
        f"random{_suffix}",
        lambda s=_suffix: _hash_bytes(s, 3000),
    )


def _png_bytes() -> bytes:
    from PIL import Image

    stream = io.BytesIO()
    Image.new("RGB", (8, 8), (200, 30, 30)).save(stream, format="PNG")
    return stream.getvalue()


_add("png_renamed_ply", "image.ply", _png_bytes)
_add("unknown_suffix_xyz", "spot.xyz", lambda: _spot().data)
_add("unknown_suffix_none", "spot", lambda: _spot().data)
_add("missing_file", "does_not_exist.ply", lambda: None)
_add("directory_named_ply", "x.ply", lambda: None)  # created as a directory

# readable, rejected by later stages ----------------------------------------------------------

_add(
    "later_one_face_obj",
    "one_face.obj",
    lambda: b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    must_fail=False,
)
_add(
    "later_one_face_ply",
    "one_face.ply",
    lambda: (
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    ),
    must_fail=False,
)
_add(
    "later_nonmanifold_fan_obj",
    "fan.obj",
    lambda: (
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\n"
        b"f 1 2 3\nf 1 2 4\nf 1 2 5\n"  # edge 1-2 shared by three triangles
    ),
    must_fail=False,
)
_add(
    "later_nonmanifold_fan_off",
    "fan.off",
    lambda: (
        b"OFF\n6 4 0\n0 0 0\n1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n"
        b"3 0 1 2\n3 0 1 3\n3 0 1 4\n3 0 1 5\n"
    ),
    must_fail=False,
)
_add(
    "later_degenerate_triangle_obj",
    "degenerate.obj",
    lambda: b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n",
    must_fail=False,
)

#: Every case id, in generation order.
CASE_IDS: tuple[str, ...] = tuple(_CASES)
#: Ids of the cases :func:`meshwm.mesh.io.read_mesh` must refuse.
MUST_FAIL_ON_READ_IDS: tuple[str, ...] = tuple(k for k, v in _CASES.items() if v[2])


def make_malformed_cases(dest: Path) -> list[MalformedCase]:
    """Write every malformed case into ``dest`` and return them in ``CASE_IDS`` order.

    Parameters
    ----------
    dest : pathlib.Path
        Existing, empty directory.  One file (or directory) is created per case, except
        ``missing_file``, whose path is deliberately left absent.

    Returns
    -------
    list of MalformedCase
        ``(case_id, path, must_fail_on_read)`` per case.
    """
    dest = Path(dest)
    cases = []
    for case_id, (file_name, builder, must_fail) in _CASES.items():
        path = dest / case_id / file_name
        path.parent.mkdir()
        if case_id == "directory_named_ply":
            path.mkdir()
        else:
            data = builder()
            if data is not None:
                path.write_bytes(data)
        cases.append(MalformedCase(case_id, path, must_fail))
    return cases
