"""The connectivity reader: the grid meshwm wrote, found in the received mesh's connectivity.

The grid's size, which vertex is which sample and its orientation come from the connectivity
alone (:func:`meshwm.gim.recover.recover_grid`: the fast path for faces in written order, the
order-free reader, pieces of a cropped grid), so the reader is blind: no vertex order, file
metadata or side information is used.  This reader also offers the decoder the received mesh
with uniform Laplacian smoothing undone (:func:`smoothing_undone`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES, check_mesh
from meshwm.errors import GridError, MeshError
from meshwm.gim.recover import RecoveredGrid, drop_irregular, recover_grid, rules_out_grid
from meshwm.mesh.clean import clean_mesh, uniform_smoothing_operator
from meshwm.readers.base import SampledImage

__all__ = [
    "EXCLUDES",
    "MOST_IMAGES",
    "UNSMOOTH_LAMBDA",
    "UNSMOOTH_STEPS",
    "read_connectivity",
    "read_grid",
    "smoothing_undone",
    "unsmoothed",
]

#: Unsmoothing: the decoder may also try the mesh with k steps of uniform Laplacian smoothing
#: with this λ undone.
UNSMOOTH_LAMBDA = 0.1
#: The k offered (0 is the mesh as received).
UNSMOOTH_STEPS = tuple(range(0, 65, 5))
_FIXED_POINT = 8
#: The images this reader offers: one grid.
MOST_IMAGES = 1
#: A meshwm grid (``--grid``) carries no surface-map mark: once one is found, the surface
#: reader (costly on a 65k-vertex grid) is not run; the radial reader still is.
EXCLUDES = ("surface",)


def read_grid(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> tuple[RecoveredGrid, NDArray[np.float64], NDArray[np.int64]]:
    """The grid of a received mesh, and the (vertices, faces) it indexes.

    Components that hold no grid (passed-through parts of the input) are ignored by
    :func:`meshwm.gim.recover.recover_grid`.  Connectivity as given first: quantised
    coordinates can make distinct vertices coincide, and merging them would change the
    connectivity.  Cleaned second: an STL file has no indices, and only merging coincident
    vertices rebuilds it.  Third, for a welded mesh (close vertices merged, which merges grid
    samples where the remesh crowded them): without the faces around the vertices no grid has
    (:func:`meshwm.gim.recover.drop_irregular`), so each merge reads as a small hole; then
    without one more ring of faces around them.  Tried only when those vertices are under 5 %
    of the vertices, i.e. when the mesh is nearly a grid.

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No meshwm grid in the connectivity.
    """
    v, f = check_mesh(vertices, faces, max_faces=max_faces)
    if rules_out_grid(len(v), f):
        # Most vertices on six triangles, or most faces without the corners of a 4-8 grid's, in
        # every component: not a grid of ours, and merging
        # exact duplicates or dropping the faces around irregular vertices cannot make it one
        # (a grid's samples are on 3-5 or 7-9 triangles; :mod:`meshwm.gim.recover.rule_out`).
        raise GridError("no meshwm grid: the connectivity is not a 4-8 grid's")
    try:
        # Every component: a cropped grid can fall apart into pieces, each read on its own.
        return recover_grid(v, f), v, f
    except GridError as as_given:
        error = as_given
    try:
        clean = clean_mesh(v, f, max_faces=max_faces)
    except MeshError:
        clean = None  # not even a clean manifold: maybe welded, else no grid of ours
    if clean is not None:
        try:
            return recover_grid(clean.vertices, clean.faces), clean.vertices, clean.faces
        except GridError:
            pass
    rv, rf, kept = drop_irregular(v, f)
    if len(rf) == 0 or len(kept) < 0.95 * len(v):
        raise error from None
    for rings in (0, 1):
        if rings:
            rv, rf, kept = drop_irregular(v, f, rings=rings)
        try:
            return recover_grid(rv, rf), rv, rf
        except GridError:
            continue
    raise error from None


def _sampled(points: NDArray[np.float64], index: NDArray) -> NDArray[np.float64]:
    """``points`` at the grid samples, NaN where ``index`` is -1."""
    if index.min() >= 0:  # a complete grid
        return points[index]
    return np.where((index >= 0)[..., None], points[np.maximum(index, 0)], np.nan)


def unsmoothed(vertices: NDArray, faces: NDArray) -> list[tuple[int, NDArray[np.float64]]]:
    """``S^-k v`` for k in :data:`UNSMOOTH_STEPS` (k > 0), with k.

    Uniform Laplacian smoothing is a known linear map of the mesh's own connectivity,
    ``S = I + λ (M - I)`` (:func:`meshwm.mesh.clean.uniform_smoothing_operator`), and
    invertible.  ``S^-1`` is applied by the fixed point ``y = v - λ (M - I) y`` (a
    contraction: the eigenvalues of ``λ (M - I)`` lie in ``[-2λ, 0]``), λ =
    :data:`UNSMOOTH_LAMBDA` (the MEPP benchmark's).

    Parameters
    ----------
    vertices : (n, 3) ndarray
    faces : (m, 3) int ndarray
        The received mesh's connectivity.
    """
    v = np.asarray(vertices, dtype=np.float64)
    mean, moved = uniform_smoothing_operator(len(v), np.asarray(faces))
    lap = sp.diags(moved.astype(np.float64)) @ (mean - sp.identity(len(v), format="csr"))
    lap = (UNSMOOTH_LAMBDA * lap).tocsr()
    out = []
    x = v.copy()
    for k in range(1, max(UNSMOOTH_STEPS) + 1):
        y = x.copy()
        for _ in range(_FIXED_POINT):
            y = x - lap @ y
        x = y
        if k in UNSMOOTH_STEPS:
            out.append((k, x))
    return out


def smoothing_undone(
    vertices: NDArray, faces: NDArray, index: NDArray
) -> list[tuple[int, NDArray[np.float64]]]:
    """The grid samples of :func:`unsmoothed` ``(vertices, faces)``, with k.

    Parameters
    ----------
    vertices, faces : ndarray
        The mesh the grid was read from.
    index : (N, N) int ndarray
        Vertex of each grid sample, -1 where the mesh lost it.
    """
    index = np.asarray(index)
    return [(k, _sampled(x, index)) for k, x in unsmoothed(vertices, faces)]


def read_connectivity(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> SampledImage:
    """Read the geometry image of a mesh meshwm wrote, from its connectivity (blind).

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose).
    max_faces : int, optional
        Refuse larger inputs.

    Returns
    -------
    SampledImage
        ``hypotheses`` is the grid reader's count (:class:`meshwm.gim.recover.RecoveredGrid`).

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No meshwm grid in the connectivity (not marked by meshwm, or re-tessellated).

    Examples
    --------
    >>> from meshwm.gim.to_mesh import geometry_image_to_mesh
    >>> n = 64
    >>> i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    >>> gim = np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)
    >>> image = read_connectivity(*geometry_image_to_mesh(gim))
    >>> image.n, bool(np.array_equal(image.samples, gim)), image.reader
    (64, True, 'connectivity')
    """
    grid, grid_v, grid_f = read_grid(vertices, faces, max_faces=max_faces)
    return SampledImage(
        samples=_sampled(grid_v, grid.index),
        hypotheses=int(grid.hypotheses),
        reader="connectivity",
        smoothing_undone=lambda: smoothing_undone(grid_v, grid_f, grid.index),
        primary=True,
    )
