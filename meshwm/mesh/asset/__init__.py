"""Mesh files as documents: every mesh to mark, and everything else the file carries, kept.

:func:`read_asset` reads an OBJ, PLY, STL, OFF, GLB or glTF file into an
:class:`~meshwm.mesh.asset.document.Asset`: its meshes (named, with triangles over the file's
own vertex positions) and, untouched, its bytes.  :meth:`Asset.with_positions
<meshwm.mesh.asset.document.Asset.with_positions>` moves the vertices; :func:`write_asset`
writes the file again changing only the moved positions (same format: UVs, normals, colours,
materials, polygons, properties, dtype, scene graph kept byte for byte) or converts it through
trimesh when the output has another suffix.  A format is one module plus one entry in
:data:`~meshwm.mesh.asset.registry.FORMATS`; ``docs/assets.md`` lists what each keeps.
Importing this package loads no mesh library (trimesh is imported for conversions only).
"""

from __future__ import annotations

from meshwm.mesh.asset.document import Asset, AssetMesh, Summary
from meshwm.mesh.asset.read import read_asset
from meshwm.mesh.asset.registry import ASSET_SUFFIXES, FORMATS
from meshwm.mesh.asset.write import asset_bytes, check_asset_output, missing_sidecars, write_asset

__all__ = [
    "ASSET_SUFFIXES",
    "FORMATS",
    "Asset",
    "AssetMesh",
    "Summary",
    "asset_bytes",
    "check_asset_output",
    "missing_sidecars",
    "read_asset",
    "write_asset",
]
