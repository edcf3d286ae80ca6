"""Sparse symmetric positive (semi-)definite solves whose cost stays linear in the mesh.

The maps (:mod:`meshwm.gim.tutte`, :mod:`meshwm.gim.parameterize`) and the transfer
(:mod:`meshwm.gim.transfer`) solve graph-Laplacian-like systems.  libigl's sparse Cholesky
(Eigen's simplicial LLᵀ with an AMD ordering) is the fastest here on small meshes, but its
fill-in grows faster than the mesh: measured on igea's Tutte system (one shared machine under
load, so slow in absolute terms), 135k unknowns 2.2-3.3 s, 538k 24-40 s (×11-12 for ×4).
CHOLMOD through ``cholespy`` grows alike (3.8 s, 21 s).  Algebraic multigrid (PyAMG's
smoothed-aggregation hierarchy as the preconditioner of conjugate gradients) grows linearly
(see :func:`_hierarchy`).

So: up to :data:`DIRECT_LIMIT` unknowns the direct factorisation, as before (the results there
are bit for bit those of earlier versions); above it AMG-preconditioned conjugate gradients.
Both are deterministic functions of the matrix and the right-hand side, so an embedder and a
blind reader that build the same system get the same solution bit for bit.
"""

from __future__ import annotations

from typing import Any

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

__all__ = ["DIRECT_LIMIT", "SpdSolver", "solve_with_fixed"]

#: The most unknowns solved by the direct factorisation; larger systems use multigrid.
DIRECT_LIMIT = 250_000
#: Relative residual the multigrid solves reach (the maps: well below a 4096-grid's sample).
TOLERANCE = 1e-10
_MAXITER = 400


def _hierarchy(matrix: sp.csr_matrix) -> Any:
    import pyamg  # only large systems need it

    # Smoothed aggregation with symmetric Gauss-Seidel (a symmetric preconditioner, as CG
    # wants).  Ruge-Stüben, used before, needed ever more iterations on the cotangent
    # Laplacian as the mesh grew (igea Loop-subdivided, 4 vertices fixed: 47 iterations at
    # 0.5M, 59 at 2M; 15.9 s and 133 s, slope 1.52); this, as configured here: 33 iterations,
    # 9.0 s at 0.5M and 217 s at 5M (docs/bench/scale.md).  The Tutte system at 0.5M: 21-22
    # iterations and 12.4 s against 28 and 8.7 s.
    # The prolongator's Jacobi smoothing weighted by Gershgorin's local bound, not by PyAMG's
    # default spectral-radius estimate (which starts from a random vector): the hierarchy, and
    # so every solve, is a deterministic function of the matrix.
    symmetric = ("gauss_seidel", {"sweep": "symmetric"})
    return pyamg.smoothed_aggregation_solver(
        sp.csr_matrix(matrix),
        symmetry="symmetric",
        smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}),
        presmoother=symmetric,
        postsmoother=symmetric,
    )


def _amg_solve(
    hierarchy: Any,
    rhs: NDArray[np.float64],
    *,
    guess: NDArray[np.float64] | None,
    tol: float,
    maxiter: int,
) -> NDArray[np.float64]:
    """Each column of ``rhs`` by AMG-preconditioned CG from ``guess`` (zero if None)."""
    out = np.empty_like(rhs)
    for c in range(rhs.shape[1]):
        x0 = None if guess is None else np.ascontiguousarray(guess[:, c])
        out[:, c] = hierarchy.solve(
            np.ascontiguousarray(rhs[:, c]), x0=x0, tol=tol, accel="cg", maxiter=maxiter
        )
    return out


def solve_with_fixed(
    quadratic: sp.spmatrix,
    fixed: NDArray[np.int64],
    values: NDArray[np.float64],
    *,
    guess: NDArray[np.float64] | None = None,
    tol: float = TOLERANCE,
) -> NDArray[np.float64]:
    """Minimise ``½ xᵀQx`` with ``x[fixed] = values``: ``Q_ff x_f = -Q_fk values``.

    Parameters
    ----------
    quadratic : (n, n) sparse matrix
        Symmetric, positive definite on the free unknowns (a Laplacian with fixed boundary).
    fixed : (k,) int64 ndarray
    values : (k, c) float64 ndarray
    guess : (n, c) float64 ndarray, optional
        A start for the iterative solve (large systems only; e.g. the previous map).
    tol : float, optional
        The relative residual of the iterative solve (large systems only).

    Returns
    -------
    (n, c) float64 ndarray

    Examples
    --------
    >>> q = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> solve_with_fixed(q, np.array([0, 2]), np.array([[0.0], [1.0]])).ravel().tolist()
    [0.0, 0.5, 1.0]
    """
    n = quadratic.shape[0]
    fixed = np.asarray(fixed, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64)
    columns = values.shape[1]
    if n - len(fixed) <= DIRECT_LIMIT:
        return np.asarray(
            igl.min_quad_with_fixed(
                sp.csc_matrix(quadratic),
                np.zeros((n, columns)),
                fixed,
                values,
                sp.csc_matrix((0, n)),
                np.zeros((0, columns)),
                True,
            ),
            dtype=np.float64,
        )
    free = np.ones(n, dtype=bool)
    free[fixed] = False
    index = np.flatnonzero(free)
    q = sp.csr_matrix(quadratic)
    q_free = q[index]
    rhs = -np.asarray(q_free[:, fixed] @ values)
    start = None if guess is None else np.asarray(guess, dtype=np.float64)[index]
    x = np.empty((n, columns))
    x[fixed] = values
    x[index] = _amg_solve(_hierarchy(q_free[:, index]), rhs, guess=start, tol=tol, maxiter=_MAXITER)
    return x


class SpdSolver:
    """``A x = b`` for one symmetric positive definite ``A`` and many ``b``.

    A direct factorisation (kept, each solve a back-substitution) up to
    :data:`DIRECT_LIMIT` unknowns, else an AMG hierarchy (kept, each solve conjugate gradients
    to the relative residual ``tol``).

    Parameters
    ----------
    matrix : (n, n) sparse matrix
    tol : float, optional
        The multigrid solves' relative residual.
    maxiter : int, optional
        At most this many conjugate-gradient iterations per solve (a cap for solves that are
        corrections within an outer iteration).
    """

    def __init__(
        self, matrix: sp.spmatrix, *, tol: float = TOLERANCE, maxiter: int = _MAXITER
    ) -> None:
        n = matrix.shape[0]
        self._n = n
        self._tol = float(tol)
        self._maxiter = int(maxiter)
        self._factor: Any = None
        self._hierarchy: Any = None
        if n <= DIRECT_LIMIT:
            self._factor = igl.min_quad_with_fixed_data()
            igl.min_quad_with_fixed_precompute(
                sp.csc_matrix(matrix),
                np.zeros(0, dtype=np.int64),
                sp.csc_matrix((0, n)),
                True,
                self._factor,
            )
        else:
            self._hierarchy = _hierarchy(sp.csr_matrix(matrix))

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A⁻¹ rhs`` for ``rhs`` of shape (n, c)."""
        rhs = np.asarray(rhs, dtype=np.float64)
        if self._factor is not None:
            none = np.zeros((0, rhs.shape[1]))
            # igl minimises ½ xᵀAx + xᵀB: B = -rhs gives A x = rhs.
            return np.asarray(igl.min_quad_with_fixed_solve(self._factor, -rhs, none, none))
        return _amg_solve(self._hierarchy, rhs, guess=None, tol=self._tol, maxiter=self._maxiter)
