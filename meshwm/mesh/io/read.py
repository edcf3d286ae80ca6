"""Read a mesh file: suffix -> reader, bytes, the format's pre-check, trimesh, the final checks."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES, check_integer, check_mesh
from meshwm.errors import MeshError
from meshwm.mesh.io.common import (
    PathLike,
    describe,
    mesh_error,
    quiet_trimesh,
    read_file_bytes,
    vertex_limit,
)
from meshwm.mesh.io.registry import reader_for

__all__ = ["read_mesh"]


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
    max_faces = check_integer(max_faces, name="max_faces", low=1)

    reader = reader_for(path)
    data = read_file_bytes(path)

    if reader.prepare is not None:
        data = reader.prepare(data)
    try:
        declared = reader.precheck(data, max_faces)
    except ValueError as exc:
        raise mesh_error(path, str(exc)) from None

    # trimesh is imported on the first read, not with meshwm.mesh.io.
    from meshwm.mesh.io.load import load_with_trimesh

    try:
        with quiet_trimesh():
            vertices, faces = load_with_trimesh(data, reader, declared)
    except MeshError as exc:
        raise mesh_error(path, str(exc)) from None
    except Exception as exc:  # trimesh and NumPy raise anything on malformed input
        raise mesh_error(
            path, f"cannot read {reader.label} file, truncated or corrupt? ({describe(exc)})"
        ) from exc

    if declared.vertices is not None and len(vertices) != declared.vertices:
        raise mesh_error(
            path,
            f"read {len(vertices)} vertices but the header declares {declared.vertices} "
            "(corrupt file?)",
        )
    if declared.polygons is not None:
        fewer = len(faces) < declared.polygons
        if fewer or (declared.exact_triangles and len(faces) != declared.polygons):
            raise mesh_error(
                path,
                f"read {len(faces)} triangles from {declared.polygons} declared faces "
                "(malformed faces?)",
            )
    if len(vertices) > vertex_limit(max_faces):
        raise mesh_error(
            path,
            f"mesh has {len(vertices)} vertices, more than the limit of {vertex_limit(max_faces)}",
        )
    try:
        return check_mesh(vertices, faces, max_faces=max_faces)
    except MeshError as exc:
        raise mesh_error(path, str(exc)) from None
