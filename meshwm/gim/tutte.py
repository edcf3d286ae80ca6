"""A Tutte map of a cut-open disk with uniform weights onto the unit square.

Uniform (graph) weights and a boundary placed by vertex count depend on the connectivity only,
so given the cut, neither a similarity, nor noise, nor the mark moves the map: the UVs are
re-derived bit for bit (to solver rounding) from a received mesh whenever
:func:`meshwm.gim.stable.stable_cut` gives the same cut.

References
----------
.. [1] W. T. Tutte, "How to draw a graph", Proc. London Math. Soc. 13, 1963,
   doi:10.1112/plms/s3-13.1.743.
.. [2] M. S. Floater, "Parametrization and smooth approximation of surface triangulations",
   CAGD 14(3), 1997, doi:10.1016/S0167-8396(96)00031-3.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._digest import freeze
from meshwm.errors import MeshError
from meshwm.gim.solve import solve_with_fixed
from meshwm.gim.stable import StableCut, cut_start, stable_cut
from meshwm.mesh.clean import unique_edges
from meshwm.mesh.edges import border_half_edges, border_loop

__all__ = ["StableMap", "boundary_loop", "restart_map", "stable_parameterize", "tutte_map"]

#: The relative residual of the map's multigrid solve (systems over
#: :data:`~meshwm.gim.solve.DIRECT_LIMIT` unknowns; smaller ones are factorised exactly).  The
#: map is a function of the connectivity and the cut alone, so an embedder and a reader that
#: receive the vertices in the same order solve the same system the same way and get the same
#: bits at any tolerance; the tolerance sets how near the exact Tutte map both are, and how
#: near the map of the same mesh with its vertices reordered is (multigrid's aggregation and
#: Gauss-Seidel follow the order).  Measured on igea Loop-subdivided twice (the cut mesh's
#: 2.1M unknowns) against 1e-10: 1e-7 moves the UVs by at most 1.7e-6 (a 4,600th of a
#: 128-grid's sample), folds no triangle (the smallest keeps 5.4e-9 of the square's area, as at
#: 1e-10), and takes 20 iterations a column instead of 30 (10.6 s against 15.1 s); at 5.3M
#: unknowns (the 5M mesh) 1.9e-6, no fold, 22 iterations against 34 (35.3 s against 44.2 s).
#: Its vertices and faces shuffled, the 2.1M mesh's map moves by 2.1e-6 (1.9e-9 at 1e-10), and
#: its kept mark, so shuffled, reads blind through the surface reader alone.
_TOLERANCE = 1e-7


class StableMap(NamedTuple):
    """A stable cut and its Tutte map.

    Attributes
    ----------
    cut : StableCut
        The cut and the mesh cut open along it.
    uv : (k, 2) float64 ndarray
        The map of each cut-mesh vertex into the unit square.
    """

    cut: StableCut
    uv: NDArray[np.float64]


def boundary_loop(faces: NDArray[np.int64], rank: NDArray[np.int64]) -> NDArray[np.int64]:
    """The disk's boundary loop in the faces' orientation, from a canonical start.

    Parameters
    ----------
    faces : (m, 3) int64 ndarray
        A consistently oriented disk.
    rank : (k,) int64 ndarray
        A canonical label of each vertex (copies of one vertex on a cut may share it).

    Returns
    -------
    (b,) int64 ndarray
        The boundary vertices in order, starting at the one of smallest ``rank``; of copies with
        the same rank, the one whose successor on the loop has the smallest rank.

    Raises
    ------
    MeshError
        If the boundary is not one simple loop.
    """
    border = border_half_edges(faces)
    if len(border) < 3 or len(np.unique(border[:, 0])) != len(border):
        raise MeshError("the cut mesh's boundary is not one simple loop")
    start = int(border[np.lexsort((rank[border[:, 1]], rank[border[:, 0]]))[0], 0])
    ring = border_loop(border, start)
    if ring is None:
        raise MeshError(f"the cut mesh's boundary is {len(border)} edges, not one loop")
    # Copies of the smallest rank whose successors are copies of one vertex too (branch
    # points of a genus > 0 cut): the start whose whole loop of ranks is smallest.
    labels = rank[ring]
    at = np.flatnonzero(labels == labels[0])
    if len(at) > 1:
        after = labels[(at[:, None] + 1) % len(ring)].ravel()
        tied = at[after == after.min()]
        if len(tied) > 1:
            best = min(tied.tolist(), key=lambda k: np.roll(labels, -k).tolist())
            ring = np.roll(ring, -best)
    return ring


def _square(count: int) -> NDArray[np.float64]:
    """``count`` points counter-clockwise on the unit square's border from (0, 0), corners at
    points ``round(k * count / 4)``, evenly spaced between them."""
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]])
    at = np.round(np.arange(5) * count / 4).astype(np.int64)
    points = np.empty((count, 2))
    for k in range(4):
        t = np.arange(at[k + 1] - at[k]) / (at[k + 1] - at[k])
        points[at[k] : at[k + 1]] = corners[k] + t[:, None] * (corners[k + 1] - corners[k])
    return points


def tutte_map(faces: NDArray[np.int64], rank: NDArray[np.int64]) -> NDArray[np.float64]:
    """Uniform-weight Tutte map of a disk onto the unit square.

    Parameters
    ----------
    faces : (m, 3) int64 ndarray
        A consistently oriented triangulated disk on vertices ``0 .. k-1``.
    rank : (k,) int64 ndarray
        A canonical label of each vertex, for the boundary's start (:func:`boundary_loop`).

    Returns
    -------
    (k, 2) float64 ndarray
        UVs in [0, 1]²: the boundary on the square's border counter-clockwise, by vertex count
        with a corner every quarter of the loop; every interior vertex the mean of its
        neighbours (one sparse solve, :func:`meshwm.gim.solve.solve_with_fixed`).

    Raises
    ------
    MeshError
        If the boundary is not one loop of at least 4 vertices.

    Examples
    --------
    >>> f = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> tutte_map(f, np.arange(5))[4].round(12).tolist()
    [0.5, 0.5]
    """
    faces = np.asarray(faces, dtype=np.int64)
    rank = np.asarray(rank, dtype=np.int64)
    k = len(rank)
    loop = boundary_loop(faces, rank)
    if len(loop) < 4:
        raise MeshError(f"the disk's boundary has {len(loop)} vertices, fewer than 4")
    uv = np.zeros((k, 2))
    uv[loop] = _square(len(loop))
    edges, _ = unique_edges(faces, keep=False)  # the cut mesh's, asked for once
    adjacency = sp.coo_matrix(
        (np.ones(2 * len(edges)), (edges.T.ravel(), edges[:, ::-1].T.ravel())), shape=(k, k)
    ).tocsr()
    # As CSR, the form the solve takes (a CSC copy was turned back: 5M vertices, 0.7 s).
    laplacian = sp.csr_matrix(sp.diags(np.asarray(adjacency.sum(axis=1)).ravel()) - adjacency)
    # The supernodal Cholesky factorisation up to DIRECT_LIMIT unknowns, multigrid to
    # _TOLERANCE above (:mod:`meshwm.gim.solve`).
    return solve_with_fixed(laplacian, loop, uv[loop], tol=_TOLERANCE)


def stable_parameterize(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    steps: int = 50,
    lam: float = 0.5,
    rank: int = 0,
) -> StableMap:
    """:func:`~meshwm.gim.stable.stable_cut` and the :func:`tutte_map` of the cut mesh.

    Parameters
    ----------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        Connected, consistently oriented, edge-manifold triangles.
    steps, lam
        The smoothing of the copy the cut's start is chosen on.
    rank : int, optional
        Which candidate start (:func:`~meshwm.gim.stable.stable_cut`).

    Returns
    -------
    StableMap
    """
    cut = stable_cut(vertices, faces, steps=steps, lam=lam, rank=rank)
    label = np.empty_like(cut.order)
    label[cut.order] = np.arange(len(cut.order))
    uv = tutte_map(cut.mesh.faces, label[cut.mesh.origin])
    freeze(uv)  # read-only: the sampling's memo keys on it (its digest kept)
    return StableMap(cut, uv)


def restart_map(
    previous: StableMap,
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    *,
    steps: int = 50,
    lam: float = 0.5,
    rank: int = 0,
) -> StableMap | None:
    """``previous`` moved to new vertex positions, if :func:`stable_parameterize` would give
    the same cut and map there; else None.

    The cut and the map depend on the geometry only through the cut's starting half-edge
    (:func:`meshwm.gim.stable.stable_cut`), so when ``faces`` are the ones ``previous`` was
    made of and the start read off the new smoothed copy is the same, the result equals
    ``stable_parameterize(vertices, faces, rank=rank)`` bit for bit, without the labelling,
    the cut and the solve.

    Parameters
    ----------
    previous : StableMap
        A map of ``faces`` (with other positions).
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray
        The faces ``previous`` was made of (not checked).
    steps, lam, rank
        As for :func:`stable_parameterize`.
    """
    start, near_ties = cut_start(vertices, faces, steps=steps, lam=lam, rank=rank)
    if start != (int(previous.cut.order[0]), int(previous.cut.order[1])):
        return None
    mesh = previous.cut.mesh._replace(vertices=np.asarray(vertices)[previous.cut.mesh.origin])
    return StableMap(previous.cut._replace(mesh=mesh, near_ties=near_ties), previous.uv)
