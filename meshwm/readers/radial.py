"""The radial reader: the spherical image of a received mesh's vertices, blind.

For the radial carrier of a mesh meshwm marked in place (:mod:`meshwm.watermark.radial`): the
received mesh's point set (the distinct positions its faces use,
:func:`meshwm.gim.sphere.point_set`) is brought into its own pose and seen from its centre
(:func:`meshwm.gim.sphere.sphere_sampling`),
at every size of :data:`RADIAL_SIZES` and for every pose its near-ties allow
(:func:`meshwm.gim.sphere.point_poses`), each image one hypothesis.  Nothing of the
connectivity, the vertex order or the file is used: a mesh whose edges were flipped, whose
quads were split the other way, whose seams were split or welded, or which arrives as an STL
soup gives the image it had.
"""

from __future__ import annotations

from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import GridError, MeshError
from meshwm.gim.sphere import point_poses, point_set, sphere_sampling
from meshwm.readers.base import LazyImages, SampledImage

__all__ = ["MIN_POINTS", "MOST_IMAGES", "RADIAL_SIZES", "SCHEME", "read_radial"]

#: The sizes of the spherical image a reader tries (the embedder picks the smallest that gives
#: each bit 3 slots: 128 for an id's 256 code bits, 256 for a 32×32 logo).
RADIAL_SIZES = (128, 256)
#: The most images this reader offers: every size for each pose (two signs of two axes, times
#: the 3 or 4 turns of a near-tied pair).
MOST_IMAGES = 16 * len(RADIAL_SIZES)
#: What decodes this reader's images (:data:`meshwm.profiles.CARRIERS`).
SCHEME = "radial"
#: A point set smaller than this carries no radial mark (a 64-bit id's code has 256 bits, and
#: the embedder refuses meshes that small anyway): the reader finds nothing.
MIN_POINTS = 128


def read_radial(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> LazyImages:
    """The spherical images of a received mesh's vertices, one per pose and size.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose, any connectivity).
    max_faces : int, optional
        Refuse larger inputs.

    Returns
    -------
    LazyImages
        For each pose (the canonical one first), one image per size of :data:`RADIAL_SIZES`;
        ``samples`` is ``(N, N, 1)``, ``scheme`` is ``"radial"``.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        Fewer than :data:`MIN_POINTS` distinct vertices, or all in a plane: no pose.
    """
    v, f = check_mesh(vertices, faces, max_faces=max_faces)
    points = point_set(v, f).points
    if len(points) < MIN_POINTS:
        raise GridError(f"{len(points)} distinct vertices, too few for a spherical image")
    try:
        poses = point_poses(points)
    except MeshError as exc:
        raise GridError(f"no spherical image: {exc}") from exc

    def make(k: int) -> SampledImage:
        pose = poses[k // len(RADIAL_SIZES)]
        n = RADIAL_SIZES[k % len(RADIAL_SIZES)]
        image = sphere_sampling(points, pose, n).image
        return SampledImage(image[..., None], 1, "radial", scheme=SCHEME)

    return LazyImages(len(poses) * len(RADIAL_SIZES), make)
