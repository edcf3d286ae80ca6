"""meshwm: blind, robust watermarking of 3D triangle meshes through geometry images.

The data flow, one module per stage (imports only go downstream):

``io`` (files) -> ``clean`` (one manifold component) -> ``geometry_image`` (N×N grid) ->
``metrics`` (distances between meshes) -> ``cli``.
"""

from meshwm._validate import MeshError
from meshwm.clean import CleanMesh, clean_mesh
from meshwm.geometry_image import GeometryImage, geometry_image_to_mesh, mesh_to_geometry_image
from meshwm.io import read_mesh, write_mesh

__version__ = "0.1.0"

__all__ = [
    "CleanMesh",
    "GeometryImage",
    "MeshError",
    "__version__",
    "clean_mesh",
    "geometry_image_to_mesh",
    "mesh_to_geometry_image",
    "read_mesh",
    "write_mesh",
]
