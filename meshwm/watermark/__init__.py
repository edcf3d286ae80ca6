"""Embedding and blind extraction on meshes: the composition of the stages, nothing more.

:func:`embed` remeshes the input to a geometry image
(:func:`meshwm.gim.remesh.mesh_to_geometry_image`), reads its own cover back exactly as
extraction will (:func:`meshwm.gim.recover.recover_grid`, fold tips of cut ends included), has
the profile (:mod:`meshwm.profiles`) mark it, and writes the marked samples back into the grid
mesh.  :func:`extract` has a reader (:mod:`meshwm.readers`) re-derive the geometry image from
the received mesh alone, then the profile decode it; :func:`verify` adds the decision
(:func:`meshwm.detect.decide`).  :class:`Decoder` reads a mesh once for many keys.

The method follows S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on
multi-resolution representation and fuzzy logic" (section 3, steps 4-5 and 10, and section 4);
the notes on each stage are in its module.
"""

from meshwm.watermark.embed import Embedded, embed, embed_gim
from meshwm.watermark.extract import (
    Decoder,
    Extracted,
    ExtractedId,
    extract,
    extract_gim,
    extract_id,
    verify,
)

__all__ = [
    "Decoder",
    "Embedded",
    "Extracted",
    "ExtractedId",
    "embed",
    "embed_gim",
    "extract",
    "extract_gim",
    "extract_id",
    "verify",
]
