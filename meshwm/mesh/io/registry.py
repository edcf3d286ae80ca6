"""The format registry: which suffixes are read and written, and by which format module.

A format is one module (``ply.py``, ``obj.py``, ...) plus one entry here: a :class:`Reader`
in :data:`READERS` for reading, a serialiser in :data:`WRITERS` for writing.  The format
modules import only the standard library and NumPy at the top, so importing the registry
(and :mod:`meshwm.mesh.io`) loads no mesh library; trimesh is imported when a file is read
(:mod:`meshwm.mesh.io.load`) or an STL or GLB file written.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io import glb, obj, off, ply, stl
from meshwm.mesh.io.common import Declared, PathLike, suffix_error

__all__ = ["READERS", "READ_SUFFIXES", "WRITERS", "WRITE_SUFFIXES", "Reader", "reader_for"]

#: A serialiser: ``(vertices, faces) -> bytes`` of the file (arrays already checked).
Writer = Callable[[NDArray[np.float64], NDArray[np.int64]], bytes]


@dataclass(frozen=True)
class Reader:
    """How to read one suffix: trimesh file type, human name, pre-check, loader options.

    ``precheck(data, max_faces)`` refuses a bad file with ``ValueError`` before trimesh sees
    it and returns what the loaded mesh must hold.  ``prepare`` (optional) rewrites the bytes
    before the pre-check and the loader.  ``check_loaded`` (optional) checks the
    ``trimesh.Scene`` just loaded against what the pre-check declared, raising
    :class:`~meshwm.errors.MeshError`.
    """

    file_type: str
    label: str
    precheck: Callable[[bytes, int], Declared]
    options: dict[str, Any] = field(default_factory=dict)
    prepare: Callable[[bytes], bytes] | None = None
    check_loaded: Callable[[Any, Declared], None] | None = None


#: Registry of readable suffixes (lower case).
READERS: dict[str, Reader] = {
    ".obj": Reader(
        "obj",
        "OBJ",
        obj.precheck,
        {"maintain_order": True, "skip_materials": True},
        prepare=obj.prepare,
    ),
    ".ply": Reader(
        "ply", "PLY", ply.precheck, {"skip_materials": True}, check_loaded=ply.check_loaded
    ),
    ".stl": Reader("stl", "STL", stl.precheck),
    ".off": Reader("off", "OFF", off.precheck),
    ".glb": Reader("glb", "GLB", glb.precheck, {"skip_materials": True}),
}

#: Registry of writable suffixes (lower case) -> serialiser.
WRITERS: dict[str, Writer] = {
    ".glb": glb.write,
    ".obj": obj.write,
    ".off": off.write,
    ".ply": ply.write,
    ".stl": stl.write,
}

#: Suffixes :func:`~meshwm.mesh.io.read_mesh` accepts.
READ_SUFFIXES: tuple[str, ...] = tuple(sorted(READERS))

#: Suffixes :func:`~meshwm.mesh.io.write_mesh` accepts.
WRITE_SUFFIXES: tuple[str, ...] = tuple(sorted(WRITERS))


def reader_for(path: PathLike) -> Reader:
    """The reader for ``path``'s (case-insensitive) suffix.

    Raises
    ------
    MeshError
        Unknown or missing suffix; the message lists the valid ones.
    """
    suffix = Path(path).suffix.lower()
    reader = READERS.get(suffix)
    if reader is None:
        raise suffix_error(path, READ_SUFFIXES)
    return reader
