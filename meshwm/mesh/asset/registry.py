"""The asset format registry: which suffixes become documents, and by which format module.

A format is one module (``obj.py``, ``ply.py``, ``stl.py``, ``off.py``, ``gltf.py``) with a
``read(data, path) -> Asset`` and a ``write(asset) -> bytes`` that changes only the moved
positions, plus one :class:`AssetFormat` entry in :data:`FORMATS`.  The cheap pre-checks of
:mod:`meshwm.mesh.io` (absurd counts, short files) run first where that package has one.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from meshwm.mesh.asset import gltf, obj, off, ply, stl
from meshwm.mesh.asset.document import Asset
from meshwm.mesh.io.common import PathLike, suffix_error

__all__ = ["ASSET_SUFFIXES", "FORMATS", "AssetFormat", "format_for"]


@dataclass(frozen=True)
class AssetFormat:
    """How one suffix is read into a document and written back.

    ``read(data, path)`` parses the bytes (``path`` locates sidecar files, may be None);
    ``write(asset)`` returns the file's bytes with the document's positions; ``label`` names
    the format in messages.
    """

    label: str
    read: Callable[[bytes, Path | None], Asset]
    write: Callable[[Asset], bytes]


#: Registry of document formats by lower-case suffix.
FORMATS: dict[str, AssetFormat] = {
    ".obj": AssetFormat("OBJ", obj.read, obj.write),
    ".ply": AssetFormat("PLY", ply.read, ply.write),
    ".stl": AssetFormat("STL", stl.read, stl.write),
    ".off": AssetFormat("OFF", off.read, off.write),
    ".glb": AssetFormat("GLB", functools.partial(gltf.read, binary=True), gltf.write),
    ".gltf": AssetFormat("glTF", functools.partial(gltf.read, binary=False), gltf.write),
}

#: Suffixes read and written as documents.
ASSET_SUFFIXES: tuple[str, ...] = tuple(sorted(FORMATS))


def format_for(path: PathLike) -> AssetFormat:
    """The format of ``path``'s (case-insensitive) suffix; a one-line error lists the valid ones."""
    suffix = Path(path).suffix.lower()
    found = FORMATS.get(suffix)
    if found is None:
        raise suffix_error(path, ASSET_SUFFIXES)
    return found
