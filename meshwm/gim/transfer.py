"""Carry a change made in a geometry image onto the mesh's own vertices.

A mark is made in the geometry image ``S @ vertices`` of a mesh under its map (the sampling of
:mod:`meshwm.gim.sampling`); the mesh keeps its vertices and faces if the change ``D`` (marked
minus unmarked image) is carried back as a vertex displacement ``d`` with ``S @ d ≈ D`` on the
covered grid points.  :func:`transfer_changes` finds that ``d`` by regularised least squares: the
data term through the sparse barycentric matrix and a smoothness term on the mesh's own edges,
so that no vertex spikes where the grid samples it sparsely or not at all.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._validate import check_integer
from meshwm.gim.sampling import Sampling
from meshwm.gim.solve import SpdSolver

__all__ = [
    "DEFAULT_PASSES",
    "DEFAULT_SMOOTHNESS",
    "ENERGIES",
    "Transfer",
    "grid_laplacian",
    "transfer_changes",
    "uniform_laplacian",
]

#: Default weight of the smoothness term relative to the data term (per row, see Notes).
DEFAULT_SMOOTHNESS = 1e-2
#: Default number of refinement passes (iterated Tikhonov, see Notes).
DEFAULT_PASSES = 3
#: Relative size of the damping that pins vertices nothing else determines.
_DAMPING = 1e-10
#: Relative residual of the multigrid solves of a large mesh's passes.
_AMG_TOLERANCE = 1e-6
#: At most this many conjugate-gradient iterations per multigrid solve of a pass (each pass
#: corrects the last; igea Loop-subdivided twice, 2.1M vertices: 3 against 5 iterations, the
#: embedding 145 s against 186 s, the same distortion with a 15 % larger step, every bit read
#: back).
_AMG_ITERATIONS = 3


def uniform_laplacian(faces: NDArray[np.int64], n_vertices: int) -> sp.csr_matrix:
    """The row-normalised uniform graph Laplacian ``L = I - D⁻¹ A`` of the mesh's edges.

    ``(L @ x)[i]`` is ``x[i]`` minus the mean of ``x`` over the neighbours of vertex ``i``; a
    vertex on no edge has an empty row.

    Parameters
    ----------
    faces : (F, 3) int64 ndarray
    n_vertices : int

    Returns
    -------
    (V, V) scipy.sparse.csr_matrix of float64

    Examples
    --------
    >>> uniform_laplacian(np.array([[0, 1, 2]]), 4).toarray()[0].tolist()
    [1.0, -0.5, -0.5, 0.0]
    """
    i = faces[:, [0, 1, 2, 1, 2, 0]].ravel()
    j = faces[:, [1, 2, 0, 0, 1, 2]].ravel()
    adjacency = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n_vertices, n_vertices))
    adjacency.data[:] = 1.0  # an edge shared by two faces counts once
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    has_edges = degree > 0
    inverse = np.where(has_edges, 1.0 / np.where(has_edges, degree, 1.0), 0.0)
    identity = sp.diags(has_edges.astype(np.float64))
    return sp.csr_matrix(identity - sp.diags(inverse) @ adjacency)


def grid_laplacian(n: int) -> sp.csr_matrix:
    """The row-normalised uniform Laplacian ``I - D⁻¹A`` of the N×N grid's 4-neighbour graph.

    The smoothness term of a :class:`Transfer` whose unknowns are the grid points' values.

    Examples
    --------
    >>> grid_laplacian(2).toarray()[0].tolist()
    [1.0, -0.5, -0.5, 0.0]
    """
    size = check_integer(n, name="n", low=2)
    index = np.arange(size * size).reshape(size, size)
    i = np.concatenate([index[:, :-1].ravel(), index[:-1, :].ravel()])
    j = np.concatenate([index[:, 1:].ravel(), index[1:, :].ravel()])
    adjacency = sp.csr_matrix(
        (np.ones(2 * len(i)), (np.concatenate([i, j]), np.concatenate([j, i]))),
        shape=(size * size, size * size),
    )
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    return sp.csr_matrix(sp.identity(size * size) - sp.diags(1.0 / degree) @ adjacency)


def _bilaplacian(laplacian: sp.csr_matrix) -> sp.csr_matrix:
    """``LᵀL``: the energy ``‖Ld‖²`` (two-ring sparsity)."""
    return sp.csr_matrix(laplacian.T @ laplacian)


def _dirichlet(laplacian: sp.csr_matrix) -> sp.csr_matrix:
    """``(D - A) / mean degree``: ``Σ_edges (dᵢ - dⱼ)²`` scaled per vertex (one-ring sparsity)."""
    adjacency = sp.csr_matrix(laplacian, copy=True)
    adjacency.setdiag(0.0)
    adjacency.eliminate_zeros()
    adjacency.data[:] = 1.0
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    mean = max(float(degree[degree > 0].mean()) if (degree > 0).any() else 1.0, 1.0)
    return sp.csr_matrix((sp.diags(degree) - adjacency) / mean)


#: The smoothness energies by name: the quadratic form ``R`` of the term ``μ dᵀRd``, built from
#: the uniform Laplacian (see :func:`transfer_changes`, Notes).
ENERGIES = {"bilaplacian": _bilaplacian, "dirichlet": _dirichlet}


def _check_inputs(
    vertices: object, faces: object, sampling: Sampling, changes: object
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Validate the arrays of :func:`transfer_changes`; return vertices, faces, flat changes."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), got {v.shape}")
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"faces must be integer triangles (F, 3), got {f.shape} {f.dtype}")
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"faces must index the {len(v)} vertices, got {f.min()}..{f.max()}")
    n = sampling.covered.shape[0]
    if sampling.matrix.shape != (n * n, len(v)):
        raise ValueError(
            f"sampling must be of the {len(v)} vertices on an N×N grid, "
            f"got a matrix of shape {sampling.matrix.shape} and covered {sampling.covered.shape}"
        )
    c = np.asarray(changes, dtype=np.float64)
    if c.shape != (n, n, 3):
        raise ValueError(f"changes must have shape ({n}, {n}, 3) like the sampling, got {c.shape}")
    if not np.isfinite(c[sampling.covered]).all():
        raise ValueError("changes must be finite on the covered grid points")
    return v, f.astype(np.int64), c.reshape(n * n, 3)


def transfer_changes(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    sampling: Sampling,
    changes: NDArray[np.float64],
    *,
    smoothness: float = DEFAULT_SMOOTHNESS,
    passes: int = DEFAULT_PASSES,
    energy: str = "bilaplacian",
) -> NDArray[np.float64]:
    """The smooth vertex displacement whose re-sampled image reproduces a change of the image.

    Parameters
    ----------
    vertices : (V, 3) float64 ndarray
        The mesh's vertex positions (only their count is used: the sampling is linear).
    faces : (F, 3) int64 ndarray
        Its triangles; their edges define the smoothness term.
    sampling : Sampling
        The mesh's sampling on the N×N grid (:func:`meshwm.gim.sampling.sampling_matrix`).
    changes : (N, N, 3) float64 ndarray
        The wanted change of the geometry image, e.g. marked minus unmarked; only its covered
        grid points are used.
    smoothness : float, optional
        Weight ``λ`` > 0 of the smoothness term relative to the data term, per row (Notes).
    passes : int, optional
        Refinement passes >= 1; each fits what the previous ones left of the data.
    energy : {"bilaplacian", "dirichlet"}, optional
        The smoothness term (:data:`ENERGIES`): ``‖Ld‖²`` (default, smoothest) or the Dirichlet
        energy (one-ring sparsity, ~6× faster to factorise, a little rougher; Notes).

    Returns
    -------
    (V, 3) float64 ndarray
        The displacement ``d``: ``sampling.matrix @ (vertices + d)`` ≈
        ``sampling.matrix @ vertices + changes`` on the covered grid points.

    Raises
    ------
    ValueError
        Shapes that do not match, non-finite changes, ``smoothness`` <= 0, ``passes`` < 1 or an
        unknown ``energy`` (the message lists the names).

    Notes
    -----
    With ``S`` the covered rows of the sampling matrix (``m`` rows, at most three barycentric
    weights each summing to 1), ``c`` the wanted change on those rows and ``L = I - D⁻¹A`` the
    row-normalised uniform Laplacian of the mesh's edges, each pass solves, coordinate by
    coordinate,

    .. math:: \\min_\\delta \\|S\\delta - r\\|^2 + \\mu\\|L\\delta\\|^2 + \\epsilon\\|\\delta\\|^2,
              \\qquad \\mu = \\lambda \\, m / V,

    through its normal equations ``(SᵀS + μLᵀL + εI) δ = Sᵀr``, factorised once and reused by
    every pass (Eigen's sparse LDLᵀ with AMD ordering through ``igl.min_quad_with_fixed``; on
    Delaunay sheets of 10k / 40k / 150k vertices it factorises in 0.07 / 0.44 / 8.0 s against
    SciPy ``splu``'s 0.26 / 1.6 / 15 s; LSMR on the stacked system and CG on the normal
    equations took 3.0 s and 0.4 s at 10k, ~60 s at 40k).  The first pass fits ``r = c``; pass
    ``k + 1`` fits the residual ``r = c - S d_k`` and adds ``d_{k+1} = d_k + δ`` (iterated
    Tikhonov): the bias the smoothness
    term puts on the data shrinks with every pass, while each correction stays smooth.  Where
    the mesh is sampled densely (``V`` < ``m``) this tends to the least-squares fit; where it is
    sampled sparsely (``V`` > ``m``, most triangles hold no grid point) to the exact fit with the
    smallest ``‖Ld‖``: plain least squares there moves only the vertices of sampled triangles
    and leaves spikes.  ``‖Lδ‖²`` (bi-Laplacian energy) rather than the Dirichlet energy because
    harmonic interpolation of isolated constraints is itself spiky.  Scaling ``μ`` by ``m / V``
    makes ``λ`` the weight of one smoothness row against one data row.  The tiny damping
    ``ε = 10⁻¹⁰ · mean diag(SᵀS + μLᵀL)`` only decides the null space of the other two terms
    (constants on a connected component no grid point samples, vertices on no face): those do
    not move, the minimum-norm choice.

    ``energy="dirichlet"`` replaces ``LᵀL`` by ``(D - A) / mean degree`` (``Σ (dᵢ - dⱼ)²`` over
    the edges), whose factor has the fill of one harmonic solve: on a 67k-vertex disk of igea at
    N = 256 it factorised in 0.37 s against 2.2 s, with the same fit (relative RMS 0.034) and
    roughness ``‖Ld‖ / ‖d‖`` 0.21 against 0.21; at N = 96 (V/N² = 7.3) 0.047 against 0.032.
    Its exact-fit limit obeys the maximum principle (no overshoot) but has a kink at every
    sampled vertex.

    The default ``λ = 10⁻²`` was measured on Delaunay sheets (V/N² 0.1–10, smooth fields, 3
    passes): ``λ`` from 10⁻⁴ to 10⁻² fit alike (relative RMS within 10⁻³ of each other),
    ``λ = 10⁻⁴`` let max |d| reach 1.5× max |c| (spikes), ``λ = 1`` cost fit (0.033 against
    0.020 relative RMS); ``scripts/check_transfer.py`` prints such figures.

    Examples
    --------
    >>> from meshwm.gim.code import grid_faces
    >>> from meshwm.gim.sampling import grid_points, sampling_matrix
    >>> uv = grid_points(9)  # a 9 × 9 vertex sheet, uv = xy
    >>> vertices = np.column_stack([uv, np.zeros(81)])
    >>> sampling = sampling_matrix(uv, grid_faces(9), 9)
    >>> changes = np.zeros((9, 9, 3))
    >>> changes[..., 2] = 1e-3 * np.sin(np.pi * uv[:, 0]).reshape(9, 9)
    >>> d = transfer_changes(vertices, grid_faces(9), sampling, changes)
    >>> bool(np.abs(sampling.matrix @ d - changes.reshape(81, 3)).max() < 1e-6)
    True
    """
    v, f, c = _check_inputs(vertices, faces, sampling, changes)
    solver = Transfer(f, sampling, n_vertices=len(v), smoothness=smoothness, energy=energy)
    return solver.apply(c.reshape((*sampling.covered.shape, 3)), passes=passes)


class Transfer:
    """:func:`transfer_changes` with its factorisation kept, for many changes on one sampling.

    The embedder moves a mesh's vertices in a few passes (embed, transfer, re-sample, embed
    again); the normal equations depend only on the sampling and the mesh's edges, so they are
    factorised once here and every :meth:`apply` costs a few back-substitutions.

    Parameters
    ----------
    faces : (F, 3) int64 ndarray
        The mesh's triangles (their edges define the smoothness term).
    sampling : Sampling
        The mesh's sampling on the N×N grid.
    n_vertices : int
        V (the sampling's columns).
    smoothness, energy
        As :func:`transfer_changes`.
    basis : (V, N²) scipy.sparse matrix, optional
        Solve for the grid points' values ``c`` instead of the vertices' moves, the move being
        ``basis @ c`` (:func:`meshwm.gim.surface.surface_basis`: each vertex's bilinear weights
        at its UV); the smoothness term is then the grid's (:func:`grid_laplacian`).

    Notes
    -----
    With a ``basis`` the normal equations are ``N² × N²`` whatever the mesh's size: a mesh many
    times finer than the grid (igea Loop-subdivided once, 537k vertices at N = 128: 33 vertices
    a covered sample) is not a system of its vertices to factorise but of the grid's 16k
    points, and its move is bilinear between them, which is what the marked image asks.  The
    vertices' own least-norm move (no basis) is the exact fit with the smallest Dirichlet
    energy, whose limit on a fine mesh has a kink at every sampled vertex.
    """

    def __init__(
        self,
        faces: NDArray[np.int64],
        sampling: Sampling,
        *,
        n_vertices: int,
        smoothness: float = DEFAULT_SMOOTHNESS,
        energy: str = "bilaplacian",
        basis: sp.csr_matrix | None = None,
    ) -> None:
        if not np.isfinite(smoothness) or smoothness <= 0:
            raise ValueError(f"smoothness must be a finite number > 0, got {smoothness}")
        if energy not in ENERGIES:
            raise ValueError(f"energy must be one of {sorted(ENERGIES)}, got {energy!r}")
        n = int(n_vertices)
        self._shape = sampling.covered.shape
        self._rows = sampling.covered.ravel()
        self._data = sp.csr_matrix(sampling.matrix[self._rows])
        self._basis = None
        if basis is not None:  # the unknowns are the grid points' values
            size = self._shape[0]
            if basis.shape != (n, size * size):
                raise ValueError(
                    f"basis must be of the {n} vertices on the {size}×{size} grid, "
                    f"got shape {basis.shape}"
                )
            self._basis = sp.csr_matrix(basis)
            self._data = sp.csr_matrix(self._data @ self._basis)
            n = size * size
        self._n = n
        self._factor: SpdSolver | None = None
        if self._data.shape[0] == 0:
            return
        laplacian = (
            uniform_laplacian(np.asarray(faces, dtype=np.int64), n)
            if self._basis is None
            else grid_laplacian(self._shape[0])
        )
        mu = smoothness * self._data.shape[0] / n
        normal = (self._data.T @ self._data + mu * ENERGIES[energy](laplacian)).tocsc()
        epsilon = _DAMPING * max(float(normal.diagonal().mean()), np.finfo(float).tiny)
        # Direct up to a few hundred thousand vertices, multigrid above (:mod:`meshwm.gim.solve`),
        # capped: each pass is a correction of the last, and a few iterations fit the data
        # about as the exact solve does (igea forced through it, N = 128, a random change:
        # relative residual 0.0603 / 0.0587 / 0.0580 after 3 / 5 / 10 iterations against
        # 0.0580 exact; two passes of 5: 0.0565); what they leave is the smoothest part,
        # which the data barely sees.
        self._factor = SpdSolver(
            normal + epsilon * sp.identity(n), tol=_AMG_TOLERANCE, maxiter=_AMG_ITERATIONS
        )

    def apply(self, changes: NDArray[np.float64], *, passes: int = DEFAULT_PASSES) -> NDArray:
        """The displacement for ``changes`` ((N, N, 3), used on covered points only).

        Returns
        -------
        (V, 3) float64 ndarray
        """
        passes = check_integer(passes, name="passes", low=1)
        c = np.asarray(changes, dtype=np.float64)
        if c.shape != (*self._shape, 3):
            raise ValueError(f"changes must have shape {(*self._shape, 3)}, got {c.shape}")
        displacement = np.zeros((self._n, 3))
        if self._factor is None:
            return displacement if self._basis is None else np.zeros((self._basis.shape[0], 3))
        target = c.reshape(-1, 3)[self._rows]
        if not np.isfinite(target).all():
            raise ValueError("changes must be finite on the covered grid points")
        for _ in range(passes):
            residual = target - self._data @ displacement
            displacement += self._factor.solve(np.asarray(self._data.T @ residual))
        return displacement if self._basis is None else np.asarray(self._basis @ displacement)
