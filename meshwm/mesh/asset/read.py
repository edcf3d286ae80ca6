"""Read a mesh file into an :class:`~meshwm.mesh.asset.document.Asset`."""

from __future__ import annotations

from pathlib import Path

from meshwm._validate import DEFAULT_MAX_FACES, check_integer
from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset
from meshwm.mesh.asset.registry import format_for
from meshwm.mesh.io.common import PathLike, describe, mesh_error, read_file_bytes, vertex_limit
from meshwm.mesh.io.registry import READERS

__all__ = ["read_asset"]


def read_asset(path: PathLike, *, max_faces: int = DEFAULT_MAX_FACES) -> Asset:
    """Read a mesh file as a document: its meshes to mark, everything else kept as it came.

    Parameters
    ----------
    path : str or os.PathLike
        An ``.obj``, ``.ply``, ``.stl``, ``.off``, ``.glb`` or ``.gltf`` file (by suffix, any
        case).  Files an OBJ names (material library, textures) or a ``.gltf`` names (buffers,
        images) are looked up next to it; external glTF buffers are read.
    max_faces : int, optional
        Refuse files with more triangles than this, or more than ``3 * max_faces + 1024``
        positions.

    Returns
    -------
    Asset
        The document (:mod:`meshwm.mesh.asset.document`).

    Raises
    ------
    MeshError
        Unknown suffix, missing, unreadable, empty, truncated or corrupt file, absurd counts,
        no faces, NaN coordinates, indices out of range, too many faces.  One line, starting
        with ``path``.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     name = os.path.join(tmp, "quad.obj")
    ...     with open(name, "wb") as f:
    ...         _ = f.write(b"o plate\\nv 0 0 0\\nv 1 0 0\\nv 1 1 0\\nv 0 1 0\\n")
    ...         _ = f.write(b"vt 0 0\\nf 1 2 3 4\\n")
    ...     asset = read_asset(name)
    >>> [(m.name, len(m.faces), m.polygons) for m in asset.meshes], asset.summary.uvs
    ([('plate', 2, 1)], 1)
    """
    max_faces = check_integer(max_faces, name="max_faces", low=1)
    fmt = format_for(path)
    data = read_file_bytes(path)
    reader = READERS.get(Path(path).suffix.lower())
    try:
        if reader is not None:
            reader.precheck(reader.prepare(data) if reader.prepare else data, max_faces)
    except ValueError as exc:
        raise mesh_error(path, str(exc)) from None
    try:
        asset = fmt.read(data, Path(path))
    except MeshError as exc:
        raise mesh_error(path, str(exc)) from None
    except Exception as exc:  # a parser on malformed bytes: index, struct, unicode errors
        raise mesh_error(
            path, f"cannot read {fmt.label} file, truncated or corrupt? ({describe(exc)})"
        ) from exc
    if not asset.meshes or not any(len(m.faces) for m in asset.meshes if m.reason is None):
        if not any(m.reason for m in asset.meshes):
            raise mesh_error(path, "file contains no faces (empty, truncated or only points?)")
    if asset.summary.triangles > max_faces:
        raise mesh_error(
            path,
            f"file has {asset.summary.triangles} triangles, more than the limit of {max_faces}",
        )
    if len(asset.original) > vertex_limit(max_faces):
        raise mesh_error(
            path,
            f"file has {len(asset.original)} vertices, more than the limit of "
            f"{vertex_limit(max_faces)}",
        )
    return asset
