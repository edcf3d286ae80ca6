"""Load checked bytes with trimesh and concatenate every mesh of the scene into two arrays.

The one module of :mod:`meshwm.mesh.io` that imports trimesh at the top; :func:`read_mesh
<meshwm.mesh.io.read_mesh>` imports it when it reads a file.
"""

from __future__ import annotations

import io

import numpy as np
import trimesh
from numpy.typing import NDArray

from meshwm.errors import MeshError
from meshwm.mesh.io.common import Declared
from meshwm.mesh.io.registry import Reader

__all__ = ["load_with_trimesh"]


def load_with_trimesh(data: bytes, reader: Reader, declared: Declared) -> tuple[NDArray, NDArray]:
    """Load ``data`` with trimesh and concatenate every mesh in the scene (transforms applied)."""
    if declared.text:
        data = data.decode("utf-8", errors="replace").encode("utf-8")
    scene = trimesh.load_scene(
        io.BytesIO(data), file_type=reader.file_type, process=False, **reader.options
    )
    if reader.check_loaded is not None:
        reader.check_loaded(scene, declared)
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
