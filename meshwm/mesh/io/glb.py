"""GLB (binary glTF 2): the pre-check of the header, the JSON chunk and the accessor counts; the
writer (trimesh's, float32 positions, its ``generator`` signature removed).
"""

from __future__ import annotations

import json
import struct
from typing import cast

import numpy as np
from numpy.typing import NDArray

from meshwm.mesh.io.common import Declared, quiet_trimesh, vertex_limit

__all__ = ["precheck", "write"]


def precheck(data: bytes, max_faces: int) -> Declared:
    """Check the GLB header and that no accessor declares more elements than the limit."""
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
    limit = vertex_limit(max_faces)
    for i, accessor in enumerate(accessors):
        count = accessor.get("count") if isinstance(accessor, dict) else None
        if isinstance(count, bool) or not isinstance(count, int) or count < 0:
            raise ValueError(f"GLB accessor {i} has an invalid count")
        if count > limit:
            raise ValueError(
                f"GLB accessor {i} declares {count} elements, more than the limit of {limit}"
            )
    return Declared()


def write(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> bytes:
    """GLB written by trimesh (float32 positions, one mesh), naming no tool."""
    import trimesh  # heavy: imported when a GLB file is written

    from meshwm.mesh.asset.convert import scrub

    with quiet_trimesh():
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        data = bytes(cast(bytes, mesh.export(file_type="glb")))
    return scrub(data, ".glb")
