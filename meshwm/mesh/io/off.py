"""OFF: the pre-check of the header counts against the limits and the size of the file; the writer.

Writing gives text with every coordinate as Python's shortest round-trip ``repr`` (float64
values read back exactly), no comment.
"""

from __future__ import annotations

import re

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io.common import COUNT, Declared, vertex_limit

__all__ = ["precheck", "write"]

_OFF_KEYWORD = re.compile(r"[A-Z0-9]*OFF")


def precheck(data: bytes, max_faces: int) -> Declared:
    """Check the OFF keyword and the vertex and face counts of the header."""
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
        if not COUNT.fullmatch(token):
            raise ValueError(f"OFF header counts must be integers >= 0, got {token[:20]!r}")
    n_vertices, n_faces = int(tokens[1]), int(tokens[2])
    if n_faces > max_faces:
        raise ValueError(f"OFF header declares {n_faces} faces, more than the limit of {max_faces}")
    if n_vertices > vertex_limit(max_faces):
        raise ValueError(
            f"OFF header declares {n_vertices} vertices, more than the limit of "
            f"{vertex_limit(max_faces)}"
        )
    # "x y z\n" takes at least 6 bytes and "3 a b c\n" at least 8.
    needed = 6 * n_vertices + 8 * n_faces - 1
    if needed > len(data):
        raise ValueError(
            f"OFF header declares {n_vertices} vertices and {n_faces} faces, which need at "
            f"least {needed} bytes, but the file has {len(data)} (truncated?)"
        )
    return Declared(vertices=n_vertices, polygons=n_faces, text=True)


def write(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """OFF text, each coordinate written as Python's shortest round-trip ``repr``."""
    header = f"OFF\n{len(vertices)} {len(faces)} 0\n"
    vertex_text = ("{!r} {!r} {!r}\n" * len(vertices)).format(*vertices.ravel().tolist())
    face_text = ("3 {} {} {}\n" * len(faces)).format(*faces.ravel().tolist())
    return (header + vertex_text + face_text).encode("ascii")
