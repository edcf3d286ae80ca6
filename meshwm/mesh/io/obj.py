"""OBJ: records trimesh would skip rewritten, face lines pre-checked, and the exact writer.

Reading rewrites indented records and a tab after the keyword (trimesh skips such lines
silently, which shifts every later index) and refuses faces with fewer than three vertices or
index 0 (which trimesh would read as vertex 1).  Writing gives text with every coordinate as
Python's shortest round-trip ``repr``, so float64 values read back exactly.
"""

from __future__ import annotations

import re

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io.common import Declared, vertex_limit

__all__ = ["precheck", "prepare", "write"]

# Records trimesh skips silently: indented lines and a tab right after the keyword.
_OBJ_ODD_RECORD = re.compile(rb"\n[ \t]+[a-z]|\n(?:v|vt|vn|f)\t")
_OBJ_INDENT = re.compile(rb"^[ \t]+", re.MULTILINE)
_OBJ_KEYWORD_TAB = re.compile(rb"^(vn|vt|v|f)\t+", re.MULTILINE)
# Searched in b"\n" + data, so each pattern starts with a literal (fast scan).
_OBJ_SHORT_FACE = re.compile(rb"\nf(?:[ \t]+[^ \t\r\n]+){0,2}[ \t\r]*(?=\n|\Z)")
_OBJ_ZERO_INDEX = re.compile(rb"\nf[ \t][^\n]*?(?<=[ \t/])[+-]?0+(?=[/ \t\r\n]|\Z)")


def prepare(data: bytes) -> bytes:
    """Rewrite OBJ records trimesh would skip silently (indented, tab after the keyword)."""
    if _OBJ_ODD_RECORD.search(b"\n" + data) is None:
        return data
    return _OBJ_KEYWORD_TAB.sub(rb"\1 ", _OBJ_INDENT.sub(b"", data))


def precheck(data: bytes, max_faces: int) -> Declared:
    """Count the face and vertex records against the limits; check every face line."""
    scan = b"\n" + data
    n_faces = scan.count(b"\nf ")
    if n_faces > max_faces:
        raise ValueError(f"OBJ file has {n_faces} faces, more than the limit of {max_faces}")
    n_vertices = scan.count(b"\nv ")
    if n_vertices > vertex_limit(max_faces):
        raise ValueError(
            f"OBJ file has {n_vertices} vertices, more than the limit of {vertex_limit(max_faces)}"
        )
    short = _OBJ_SHORT_FACE.search(scan)
    if short is not None:
        line = scan.count(b"\n", 0, short.start() + 1)
        raise ValueError(f"OBJ face on line {line} has fewer than 3 vertices")
    zero = _OBJ_ZERO_INDEX.search(scan)
    if zero is not None:
        line = scan.count(b"\n", 0, zero.start() + 1)
        raise ValueError(f"OBJ face on line {line} uses index 0 (OBJ indices start at 1)")
    return Declared(polygons=n_faces, text=True)


def write(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """OBJ text with each coordinate written as Python's shortest round-trip ``repr``."""
    vertex_text = ("v {!r} {!r} {!r}\n" * len(vertices)).format(*vertices.ravel().tolist())
    face_text = ("f {} {} {}\n" * len(faces)).format(*(faces + 1).ravel().tolist())
    return (vertex_text + face_text).encode("ascii")
