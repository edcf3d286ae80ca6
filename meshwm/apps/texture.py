"""A file's look, per face: its texture (or colours) sampled once per triangle, for the pictures.

:func:`texture_colors` loads a file with its materials through trimesh's scene graph (the OBJ's
``.mtl`` and images, a glTF's textures), applies the node transforms and gives each triangle
one colour: the texture at the mean of its corners' UVs, else its vertex colours, else its
material's colour.  :func:`meshwm.apps.render.render_views` draws them flat-shaded
(``meshwm render --texture``): coarse, but a checker texture shows at a glance whether the UVs
and the material came through a marking intact.
"""

from __future__ import annotations

import os
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["Textured", "texture_colors"]

_PLAIN = np.array([0.74, 0.78, 0.86])  # the renderer's colour of a mesh without a look


class Textured(NamedTuple):
    """The triangles of a file in world space and one RGB colour (0..1) per triangle."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    colors: NDArray[np.float64]
    textured: int  # triangles coloured from a texture image


def _sample(image: Any, uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """The image's colour (nearest pixel) at each UV (wrapped; v runs up the image)."""
    pixels = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0
    height, width = pixels.shape[:2]
    u, v = uv[:, 0] % 1.0, uv[:, 1] % 1.0
    x = np.clip(np.rint(u * (width - 1)).astype(int), 0, width - 1)
    y = np.clip(np.rint((1.0 - v) * (height - 1)).astype(int), 0, height - 1)
    return pixels[y, x]


def _look(mesh: Any) -> tuple[NDArray[np.float64], int]:
    """One colour per face of a trimesh mesh, and how many came from a texture."""
    m = len(mesh.faces)
    visual = mesh.visual
    material = getattr(visual, "material", None)
    image = getattr(material, "image", None) or getattr(material, "baseColorTexture", None)
    uv = getattr(visual, "uv", None)
    if image is not None and uv is not None and len(uv) == len(mesh.vertices):
        return _sample(image, np.asarray(uv)[mesh.faces].mean(axis=1)), m
    if getattr(visual, "kind", None) == "vertex":
        rgb = np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
        return rgb[mesh.faces].mean(axis=1), 0
    color = getattr(material, "main_color", None)
    if color is not None:
        return np.tile(np.asarray(color[:3], dtype=np.float64) / 255.0, (m, 1)), 0
    return np.tile(_PLAIN, (m, 1)), 0


def texture_colors(path: str | os.PathLike[str]) -> Textured:
    """The triangles of the file at ``path`` with one colour each (see the module notes).

    Raises
    ------
    MeshError
        trimesh cannot load the file, or it holds no triangles.
    """
    import trimesh

    from meshwm.errors import MeshError
    from meshwm.mesh.io.common import describe, quiet_trimesh

    try:
        with quiet_trimesh():
            scene = trimesh.load_scene(os.fspath(path), process=False)
    except Exception as exc:  # trimesh raises anything on what it cannot read
        raise MeshError(f"{path}: cannot load its materials ({describe(exc)})") from exc
    vertices, faces, colors = [], [], []
    textured = offset = 0
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        mesh = scene.geometry[name]
        if not isinstance(mesh, trimesh.Trimesh) or not len(mesh.faces):
            continue
        rgb, n_textured = _look(mesh)
        vertices.append(trimesh.transformations.transform_points(mesh.vertices, transform))
        faces.append(np.asarray(mesh.faces, dtype=np.int64) + offset)
        colors.append(rgb)
        textured += n_textured
        offset += len(mesh.vertices)
    if not faces:
        raise MeshError(f"{path}: no triangles to draw")
    return Textured(
        np.concatenate(vertices), np.concatenate(faces), np.clip(np.concatenate(colors), 0, 1),
        textured,
    )  # fmt: skip
