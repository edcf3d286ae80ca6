"""meshwm: blind, robust watermarking of 3D triangle meshes through geometry images.

The data flow, one module per stage (imports only go downstream):

``io`` (files) -> ``clean`` (one manifold component) -> ``geometry_image`` (N×N grid) ->
``wavelet`` (Haar multi-resolution representation) -> ``fuzzy`` (perceptual mask) ->
``metrics`` (distances) -> ``cli``;
the mark itself: ``mark`` (binary images) -> ``scramble`` (Arnold transform).
"""

from meshwm.errors import MeshError
from meshwm.gim.remesh import GeometryImage, geometry_image_to_mesh, mesh_to_geometry_image
from meshwm.mesh.clean import CleanMesh, clean_mesh
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.message.mark import default_mark, load_mark, save_mark
from meshwm.message.scramble import arnold_period, arnold_scramble, arnold_unscramble
from meshwm.signal.fuzzy import infer_strength, strength_class
from meshwm.signal.wavelet import (
    dyadic_decompose,
    dyadic_reconstruct,
    mrr_decompose,
    mrr_reconstruct,
)

__version__ = "0.1.0"

__all__ = [
    "CleanMesh",
    "GeometryImage",
    "MeshError",
    "__version__",
    "arnold_period",
    "arnold_scramble",
    "arnold_unscramble",
    "clean_mesh",
    "default_mark",
    "dyadic_decompose",
    "dyadic_reconstruct",
    "geometry_image_to_mesh",
    "infer_strength",
    "load_mark",
    "mesh_to_geometry_image",
    "mrr_decompose",
    "mrr_reconstruct",
    "read_mesh",
    "save_mark",
    "strength_class",
    "write_mesh",
]
