"""STL (ASCII or binary): the pre-check of the triangle count, and the binary writer.

Binary STL is recognised the way trimesh does it (the size matches the header's triangle count
exactly), otherwise a file starting with ``solid`` is ASCII.  Writing goes through trimesh:
float32 coordinates, one vertex triple per triangle, a zeroed 80-byte header.
"""

from __future__ import annotations

import struct
from typing import cast

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io.common import Declared, quiet_trimesh

__all__ = ["precheck", "write"]

_STL_HEADER = 84
_STL_RECORD = 50


def precheck(data: bytes, max_faces: int) -> Declared:
    """Check the triangle count of a binary STL, or count the facets of an ASCII one."""
    if len(data) >= _STL_HEADER:
        (n_binary,) = struct.unpack_from("<I", data, 80)
        if len(data) == _STL_HEADER + _STL_RECORD * n_binary:
            # trimesh tries binary first and accepts it when the size matches exactly.
            if n_binary > max_faces:
                raise ValueError(
                    f"STL header declares {n_binary} triangles, more than the limit of {max_faces}"
                )
            return Declared(polygons=n_binary, exact_triangles=True)
    else:
        n_binary = None
    if data.lstrip()[:5].lower() == b"solid":
        n_facets = data.lower().count(b"endfacet")
        if n_facets > max_faces:
            raise ValueError(f"STL file has {n_facets} facets, more than the limit of {max_faces}")
        return Declared(polygons=n_facets, exact_triangles=True, text=True)
    if n_binary is None:
        raise ValueError(f"file of {len(data)} bytes is too short for a binary STL")
    raise ValueError(
        f"binary STL header declares {n_binary} triangles, which need "
        f"{_STL_HEADER + _STL_RECORD * n_binary} bytes, but the file has {len(data)} "
        "(truncated or not an STL file?)"
    )


def write(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """Binary STL written by trimesh (float32 coordinates, zeroed 80-byte header)."""
    import trimesh  # heavy: imported when an STL file is written

    with quiet_trimesh():
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        return bytes(cast(bytes, mesh.export(file_type="stl")))
