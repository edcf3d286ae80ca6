"""A document written in another format: converted by trimesh, tool names scrubbed.

Same-format writes change only positions (the format modules); a conversion (``-o`` names
another suffix) goes through :mod:`trimesh`'s scene graph, which carries what it reads and the
target format holds: names, transforms, UVs, materials and textures into glTF; the geometry,
and what each writer supports, into the others.  What is lost shows in the summaries
(:meth:`~meshwm.mesh.asset.document.Summary.changes_from`).  trimesh signs its files; the
signature is removed, so no output names a tool.
"""

from __future__ import annotations

import io
import json
import re
import struct
from typing import Any

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


def convert(asset: Asset, same_format: bytes, suffix: str) -> bytes:
    """``asset`` (whose own-format bytes are ``same_format``) as a ``suffix`` file."""
    import trimesh  # heavy: only for conversions

    options: dict[str, Any] = {"process": False}
    if asset.suffix == ".obj":
        options["maintain_order"] = True
    if asset.path is not None:
        options["resolver"] = trimesh.resolvers.FilePathResolver(str(asset.path))
    try:
        with quiet_trimesh():
            scene = trimesh.load_scene(
                io.BytesIO(same_format), file_type=asset.suffix[1:], **options
            )
            if suffix == ".glb":
                out: Any = scene.export(file_type="glb")
            elif suffix == ".gltf":
                from trimesh.exchange.gltf import export_gltf

                out = export_gltf(scene, embed_buffers=True)["model.gltf"]
            elif suffix == ".obj":
                out = scene.export(file_type="obj", include_texture=False)
            else:
                out = scene.to_geometry().export(None, file_type=suffix[1:])
    except Exception as exc:  # trimesh raises anything on what it cannot convert
        raise MeshError(f"cannot convert {asset.suffix} to {suffix} ({describe(exc)})") from exc
    data = out.encode("utf-8") if isinstance(out, str) else bytes(out)
    return scrub(data, suffix)
