"""A document written in another format: converted by trimesh, tool names scrubbed.

Same-format writes change only positions (the format modules); a conversion (``-o`` names
another suffix) goes through :mod:`trimesh`'s scene graph, which carries what it reads and the
target format holds: names, transforms, UVs, materials and textures into glTF; the geometry,
and what each writer supports, into the others.  trimesh splits a mesh by material (an OBJ's
``usemtl`` groups, a glTF mesh's primitives); the pieces of one document mesh are put back
together (their materials packed into one texture atlas by trimesh), since each mesh carries
its mark whole and half a mesh would not read.  What is lost shows in the summaries
(:meth:`~meshwm.mesh.asset.document.Summary.changes_from`).  trimesh signs its files; the
signature is removed, so no output names a tool.
"""

from __future__ import annotations

import io
import json
import re
import struct
from typing import Any

import numpy as np

from meshwm.errors import MeshError
from meshwm.mesh.asset.document import Asset
from meshwm.mesh.io.common import describe, quiet_trimesh

__all__ = ["convert", "scrub"]

_SIGNED = re.compile(
    rb"^(?:#|comment)[^\n]*(?:trimesh|mikedh)[^\n]*\n", re.MULTILINE | re.IGNORECASE
)


def _scrub_gltf(gltf: dict[str, Any]) -> dict[str, Any]:
    asset = gltf.get("asset")
    if isinstance(asset, dict) and "generator" in asset:
        del asset["generator"]
    return gltf


def scrub(data: bytes, suffix: str) -> bytes:
    """``data`` without trimesh's signature (an OBJ comment, a PLY header comment, glTF's
    ``asset.generator``).

    Examples
    --------
    >>> scrub(b"# https://github.com/mikedh/trimesh\\nv 0 0 0\\n", ".obj")
    b'v 0 0 0\\n'
    """
    if suffix == ".glb":
        (json_length,) = struct.unpack_from("<I", data, 12)
        gltf = _scrub_gltf(json.loads(data[20 : 20 + json_length]))
        text = json.dumps(gltf, separators=(",", ":")).encode("utf-8")
        text += b" " * (-len(text) % 4)
        rest = data[20 + json_length :]
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + rest
        return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks
    if suffix == ".gltf":
        return json.dumps(_scrub_gltf(json.loads(data)), indent=2).encode("utf-8")
    if suffix == ".ply":
        end = data.find(b"end_header")
        return _SIGNED.sub(b"", data[:end]) + data[end:]
    if suffix == ".obj":
        return _SIGNED.sub(b"", data)
    return data


def _regroup(scene: Any, stored: Asset) -> Any:
    """``scene`` with the pieces trimesh made of each document mesh joined into one geometry.

    ``stored`` is the document as written in its own format (positions as the file stores
    them, which is what trimesh read).  A piece belongs to the mesh that holds the position
    nearest its first vertex; a joined mesh keeps the node (transform) of its first piece and
    takes the document mesh's name.
    """
    import trimesh
    from scipy.spatial import cKDTree

    owner = np.full(len(stored.positions), -1, dtype=np.int64)
    for k, mesh in enumerate(stored.meshes):
        owner[mesh.rows] = k
    tree = cKDTree(stored.positions)
    groups: dict[int | str, list[tuple[str, Any, Any]]] = {}
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        key: int | str = f"node {node}"
        if isinstance(geometry, trimesh.Trimesh) and len(geometry.vertices) and len(owner):
            _, row = tree.query(np.asarray(geometry.vertices[0], dtype=np.float64))
            if owner[row] >= 0:
                key = int(owner[row])
        groups.setdefault(key, []).append((node, geometry, transform))
    out = trimesh.Scene()
    for key, pieces in groups.items():
        node, geometry, transform = pieces[0]
        if len(pieces) > 1:
            geometry = trimesh.util.concatenate([p[1] for p in pieces])
        name = stored.meshes[key].name if isinstance(key, int) else node
        out.add_geometry(geometry, node_name=name, geom_name=name, transform=transform)
    return out


def convert(asset: Asset, same_format: bytes, suffix: str) -> bytes:
    """``asset`` (whose own-format bytes are ``same_format``) as a ``suffix`` file."""
    import trimesh  # heavy: only for conversions

    # No ``maintain_order`` for an OBJ: trimesh then splits vertices at UV seams, which is how
    # its scene carries UVs and textures (positions are unchanged, copies move together).
    options: dict[str, Any] = {"process": False}
    if asset.path is not None:
        options["resolver"] = trimesh.resolvers.FilePathResolver(str(asset.path))
    try:
        with quiet_trimesh():
            scene = trimesh.load_scene(
                io.BytesIO(same_format), file_type=asset.suffix[1:], **options
            )
            from meshwm.mesh.asset.registry import FORMATS

            scene = _regroup(scene, FORMATS[asset.suffix].read(same_format, asset.path))
            if suffix == ".glb":
                out: Any = scene.export(file_type="glb", include_normals=True)
            elif suffix == ".gltf":
                from trimesh.exchange.gltf import export_gltf

                out = export_gltf(scene, embed_buffers=True, include_normals=True)["model.gltf"]
            elif suffix == ".obj":
                out = scene.export(file_type="obj", include_texture=False)
            else:
                out = scene.to_geometry().export(None, file_type=suffix[1:])
    except Exception as exc:  # trimesh raises anything on what it cannot convert
        raise MeshError(f"cannot convert {asset.suffix} to {suffix} ({describe(exc)})") from exc
    data = out.encode("utf-8") if isinstance(out, str) else bytes(out)
    return scrub(data, suffix)
