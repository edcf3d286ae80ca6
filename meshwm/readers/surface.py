"""The surface reader: the geometry image re-derived from any received mesh, blind.

For a mesh meshwm marked in place (its own vertices and faces, :mod:`meshwm.watermark.keep`):
the received mesh is cleaned, cut and mapped exactly as the embedder did
(:func:`meshwm.gim.surface.surface_of`), from its geometry and connectivity alone: no vertex
order, file metadata or side information is used, and the map is one the mark, noise, smoothing,
quantisation and similarities do not move.  The mesh is then sampled at every size of
:data:`meshwm.gim.surface.SURFACE_SIZES` (the embedder picked one; the decoder tries each, and
each counts as a hypothesis).  The map's one geometric choice, the cut's start (the vertex
farthest from the centroid on a smoothed copy), can be a near-tie that the mark or noise tips;
the runner-up starts (:data:`meshwm.gim.surface.SURFACE_RANKS`) are offered too, mapped only if
the decoder gets that far, and so is the runner-up first edge of a tip whose two longest edges
are a near-tie (:attr:`meshwm.gim.stable.StableCut.near_ties`: the genus-8 plate's corner).  The decoder is also offered the received mesh with uniform
Laplacian smoothing undone, sampled the same way.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import GridError, MeshError
from meshwm.gim.surface import (
    SURFACE_RANKS,
    SURFACE_SIZES,
    Surface,
    SurfaceImage,
    remap_surface,
    sample_surface,
    surface_of,
)
from meshwm.readers.base import LazyImages, SampledImage
from meshwm.readers.connectivity import unsmoothed

__all__ = ["read_surface"]


def _undone(
    positions: NDArray[np.float64], faces: NDArray[np.int64], image: SurfaceImage
) -> list[tuple[int, NDArray[np.float64]]]:
    out = []
    for k, x in unsmoothed(positions, faces):
        samples = np.asarray(image.matrix @ x).reshape(image.samples.shape)
        samples[~image.covered] = np.nan
        out.append((k, samples))
    return out


def read_surface(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> LazyImages:
    """Sample a received mesh through its re-derived stable map, at every size and start.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose).
    max_faces : int, optional
        Refuse larger inputs.

    Returns
    -------
    LazyImages
        For each candidate start of :data:`~meshwm.gim.surface.SURFACE_RANKS` (the farthest
        vertex first), then each near-tie start of the received mesh, one image per size of :data:`~meshwm.gim.surface.SURFACE_SIZES`, each
        one hypothesis; the maps of the runner-up starts are made only when asked for.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        A surface the map cannot open (non-manifold, non-orientable, too small).
    """
    v, f = check_mesh(vertices, faces, max_faces=max_faces)  # unusable arrays: MeshError
    try:
        first = surface_of(v, f, max_faces=max_faces)
    except MeshError as merged:
        # Coarse quantisation makes distinct vertices coincide; merged, they can pinch the
        # surface into a non-manifold: read the connectivity as given instead.
        try:
            first = surface_of(v, f, max_faces=max_faces, merge=False)
        except MeshError:  # a surface the map cannot open: nothing to read
            raise GridError(f"the surface cannot be mapped: {merged}") from merged
    surfaces: dict[int, Surface] = {SURFACE_RANKS[0]: first}
    # Tips whose first edge is a near-tie are also started along the runner-up edge.
    ranks = (*SURFACE_RANKS, *(r for r in first.map.cut.near_ties if r not in SURFACE_RANKS))

    def make(k: int) -> SampledImage:
        rank = ranks[k // len(SURFACE_SIZES)]
        if rank not in surfaces:
            try:
                surfaces[rank] = remap_surface(first, first.positions, rank=rank)
            except MeshError:
                surfaces[rank] = first  # no such start (a tiny mesh): the first map again
        surface = surfaces[rank]
        image = sample_surface(surface, size=SURFACE_SIZES[k % len(SURFACE_SIZES)])
        return SampledImage(
            samples=image.samples,
            hypotheses=1,
            reader="surface",
            smoothing_undone=lambda: _undone(surface.positions, surface.faces, image),
        )

    return LazyImages(len(ranks) * len(SURFACE_SIZES), make)
