"""Sparse symmetric positive (semi-)definite solves whose cost stays near-linear in the mesh.

The maps (:mod:`meshwm.gim.tutte`, :mod:`meshwm.gim.parameterize`) and the transfer
(:mod:`meshwm.gim.transfer`) solve graph-Laplacian-like systems.  Measured with
``scripts/bench_solve.py`` on igea's graph Laplacian with four vertices fixed (2026-12-03, one
core busy; libigl / CHOLMOD / multigrid): 134k unknowns 1.96 / 0.52 / 1.49 s, 537k 31.0 / 3.2 /
5.8 s; the transfer's normal equations 1.91 / 0.59 / 8.7 s and 26.0 / 3.1 / 56.6 s.  libigl's
sparse Cholesky is Eigen's *simplicial* LLᵀ (AMD ordering), whose cost grows fast; CHOLMOD's
*supernodal* factorisation does the same elimination with dense BLAS on the supernodes (the copy
of CHOLMOD that CVXOPT ships in its wheels, the one packaged with a BLAS for every platform;
scikit-sparse has no wheels).  At 2.1M unknowns it is no faster than multigrid (23.6 s against
24.0 s) and needs 4.4 GB.  Algebraic multigrid (PyAMG's smoothed-aggregation hierarchy as the
preconditioner of conjugate gradients) grows linearly in time and memory
(see :func:`_hierarchy`).

So: up to :data:`DIRECT_LIMIT` unknowns the supernodal Cholesky factorisation; above it
AMG-preconditioned conjugate gradients.  Both are deterministic functions of the matrix and the
right-hand side (the supernodal solve gives the same bits with 1 or 2 BLAS threads), so an
embedder and a blind reader that build the same system get the same solution bit for bit.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

import igl
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm._digest import arrays_key

__all__ = ["DIRECT_LIMIT", "SpdSolver", "solve_with_fixed"]

#: The most unknowns solved by the direct factorisation; larger systems use multigrid (CHOLMOD's
#: factor of a 2.1M-vertex Laplacian is no faster than multigrid and takes 4.4 GB; 1M would
#: break issue 16's 2 GB at 1M vertices).
DIRECT_LIMIT = 600_000
#: Relative residual the multigrid solves reach (the maps: well below a 4096-grid's sample).
TOLERANCE = 1e-10
_MAXITER = 400


#: PyAMG's defaults for the hierarchy's size: at most this many levels, and a level of at most
#: this many unknowns is the coarsest.
_MAX_LEVELS = 10
_MAX_COARSE = 10


def _hierarchy(matrix: sp.csr_matrix) -> Any:
    """PyAMG's smoothed-aggregation hierarchy of ``matrix``, built one level at a time.

    Smoothed aggregation with Gauss-Seidel: on the finest level one forward sweep before the
    coarse correction and one backward sweep after it, on the coarser levels a symmetric sweep
    (forward then backward) each time; either way the V-cycle is a symmetric preconditioner, as
    CG wants.  The finest level is where a V-cycle spends its time (igea at 5M vertices: 5.0M
    unknowns, the next level 313k), and PyAMG's Gauss-Seidel holds the GIL, so the two columns
    :func:`_amg_solve` runs at once wait for each other there.  The grid mode's two stretch
    solves at 5M vertices, in two threads: symmetric sweeps on every level 17.2-18.3 and
    14.7-15.7 s (25 and 22 iterations a column); one sweep each way on the finest level
    11.3-12.0 and 9.4-9.9 s (26 and 22 iterations); one each way on every level 13.7 and 13.0 s
    (31-32 and 28); two each way on every level 15.3 and 15.4 s (24 and 21).  The embedding
    73-76 -> 63.5 s, the kept mode's 94.2 -> 82.6 s.  Ruge-Stüben, used before, needed ever more
    iterations on the cotangent Laplacian as the mesh grew (igea Loop-subdivided, 4 vertices
    fixed: 47 iterations at 0.5M, 59 at 2M; 15.9 s and 133 s, slope 1.52); smoothed aggregation
    (then with symmetric sweeps throughout): 33 iterations, 9.0 s at 0.5M and 217 s at 5M
    (docs/bench/scale.md).  The Tutte system at 0.5M: 21-22 iterations and 12.4 s against 28 and
    8.7 s.  The prolongator's Jacobi smoothing is weighted by Gershgorin's local bound, not by
    PyAMG's default spectral-radius estimate (which starts from a random vector): the hierarchy,
    and so every solve, is a deterministic function of the matrix.

    One unknown per node, so PyAMG makes the coarse matrices and the transfer operators BSR
    of 1×1 blocks, whose products leave their indices unsorted; the next level's smoothing
    then sorts them inside ``abs`` (2.6 s a hierarchy at 5M unknowns), and their Gauss-Seidel
    and products run slower than CSR's on the same entries (the Tutte system of igea at 2.1M
    vertices 6.8 -> 5.5 s a column).  So each level is built by PyAMG from the last one's
    matrix as sorted CSR (PyAMG's own steps and options, level by level: its candidates
    improved on the finest level only, as its default), and its operators kept as CSR.

    No strength-of-connection matrix: PyAMG's default (symmetric, theta 0) keeps every entry
    of the level's matrix, and the aggregation reads only its pattern (the prolongator's
    smoothing, unfiltered, does not read it at all), so the level's own matrix gives the same
    hierarchy, operator for operator, without a scaled copy of it (2.1M unknowns: 2.11 ->
    1.45 s a hierarchy; igea at 5M vertices, N = 256: 86.8 -> 80.5 s, the peak 7.35 -> 6.97
    GiB, the same output).
    """
    import pyamg
    from pyamg.multilevel import MultilevelSolver
    from pyamg.relaxation.smoothing import change_smoothers

    options: dict[str, Any] = {
        "symmetry": "symmetric",
        "strength": None,
        "smooth": ("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}),
        "max_levels": 2,
        "max_coarse": _MAX_COARSE,
    }
    a = sp.csr_array(matrix)
    a.sort_indices()
    candidates = None
    levels: list[Any] = []
    while True:
        improve = {} if not levels else {"improve_candidates": None}
        part = pyamg.smoothed_aggregation_solver(a, B=candidates, **options, **improve).levels
        fine = part[0]
        fine.A = a
        if len(part) == 1:  # too small to coarsen
            levels.append(fine)
            break
        for name in ("P", "R"):
            operator = sp.csr_array(getattr(fine, name))
            operator.sort_indices()
            setattr(fine, name, operator)
        levels.append(fine)
        a = sp.csr_array(part[1].A)
        a.sort_indices()
        candidates = part[1].B
        if len(levels) + 1 >= _MAX_LEVELS or a.shape[0] <= _MAX_COARSE:
            last = MultilevelSolver.Level()
            last.A, last.B = a, candidates
            levels.append(last)
            break
    hierarchy = MultilevelSolver(levels)
    change_smoothers(hierarchy, *_smoothers(len(levels)))
    return hierarchy


def _smoothers(levels: int) -> tuple[list[tuple[str, dict]], list[tuple[str, dict]]]:
    """The pre- and post-smoothers of a hierarchy of ``levels`` levels (:func:`_hierarchy`):
    one forward and one backward Gauss-Seidel sweep on the finest level, a symmetric sweep on
    each coarser one but the coarsest (solved directly)."""
    coarse = [("gauss_seidel", {"sweep": "symmetric"})] * (levels - 2)
    return (
        [("gauss_seidel", {"sweep": "forward"}), *coarse],
        [("gauss_seidel", {"sweep": "backward"}), *coarse],
    )


#: The fill-reducing orderings of the last few sparsity patterns factorised (by a digest of the
#: pattern): the stretch reweighting of a map factors one pattern with new weights up to 8
#: times, and CHOLMOD's analysis with a given ordering costs a third of finding one (537k
#: unknowns: 0.27 s against 0.8-1.1 s) and gives the same factor bit for bit.
_ORDERINGS: OrderedDict[tuple, NDArray[np.int64]] = OrderedDict()
_ORDERINGS_SIZE = 4
_CHOLMOD_LOCK = threading.Lock()


class _Cholesky:
    """CHOLMOD's supernodal LLᵀ of a symmetric positive definite matrix (through CVXOPT)."""

    def __init__(self, matrix: sp.spmatrix) -> None:
        import cvxopt
        from cvxopt import cholmod

        lower = sp.csc_matrix(sp.tril(matrix, format="csc"))
        lower.sum_duplicates()
        lower.sort_indices()
        n = lower.shape[0]
        columns = np.repeat(np.arange(n, dtype=np.int64), np.diff(lower.indptr))
        self._matrix = cvxopt.spmatrix(
            cvxopt.matrix(np.asarray(lower.data, dtype=np.float64)),
            cvxopt.matrix(np.asarray(lower.indices, dtype=np.int64)),
            cvxopt.matrix(columns),
            (n, n),
        )
        key = arrays_key(lower.indptr, lower.indices)
        with _CHOLMOD_LOCK:  # CVXOPT's options are module-wide
            ordering = _ORDERINGS.get(key)
            cholmod.options["supernodal"] = 2  # CHOLMOD_AUTO: supernodal where it pays
            cholmod.options["postorder"] = True
            if ordering is None:
                cholmod.options["nmethods"] = 0  # CHOLMOD's default choice of ordering
                self._factor = cholmod.symbolic(self._matrix, uplo="L")
            else:
                cholmod.options["nmethods"] = 1  # the given ordering only
                self._factor = cholmod.symbolic(self._matrix, p=cvxopt.matrix(ordering), uplo="L")
                cholmod.options["nmethods"] = 0
        cholmod.numeric(self._matrix, self._factor)  # ArithmeticError: not positive definite
        if ordering is None:
            # The ordering chosen: P applied to 0 .. n-1 (exact in float64).
            at = cvxopt.matrix(np.arange(n, dtype=np.float64))
            cholmod.solve(self._factor, at, sys=7)
            found = np.array(at, dtype=np.float64).ravel().astype(np.int64)
            with _CHOLMOD_LOCK:
                _ORDERINGS[key] = found
                while len(_ORDERINGS) > _ORDERINGS_SIZE:
                    _ORDERINGS.popitem(last=False)

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        import cvxopt
        from cvxopt import cholmod

        b = cvxopt.matrix(np.asfortranarray(rhs, dtype=np.float64))
        cholmod.solve(self._factor, b)
        return np.array(b, dtype=np.float64).reshape(rhs.shape)


def _v_cycle(hierarchy: Any, level: int, x: NDArray[np.float64], b: NDArray[np.float64]) -> None:
    """One V-cycle on ``A x = b`` at ``level``, in place: PyAMG's own cycle, step for step."""
    this = hierarchy.levels[level]
    a = this.A
    this.presmoother(a, x, b)
    coarse_b = this.R @ (b - a @ x)
    coarse_x = np.zeros_like(coarse_b)
    if level == len(hierarchy.levels) - 2:
        coarse_x[:] = hierarchy.coarse_solver(hierarchy.levels[-1].A, coarse_b)
    else:
        _v_cycle(hierarchy, level + 1, coarse_x, coarse_b)
    x += this.P @ coarse_x
    this.postsmoother(a, x, b)


def _precondition(hierarchy: Any, r: NDArray[np.float64]) -> NDArray[np.float64]:
    """One V-cycle from zero: what ``hierarchy.aspreconditioner()`` applies, without its two
    residual norms."""
    if len(hierarchy.levels) == 1:
        return np.asarray(hierarchy.coarse_solver(hierarchy.levels[0].A, r))
    x = np.zeros_like(r)
    _v_cycle(hierarchy, 0, x, r)
    return x


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    """``a · b`` summed in an order of its own (einsum's), not BLAS's: BLAS splits a long dot
    product between its threads, so its rounding, and every iterate after it, depended on the
    machine's cores (igea Loop-subdivided twice, 2.1M vertices: another marked mesh with one
    thread than with two)."""
    return float(np.einsum("i,i->", a, b))


def _pcg(
    hierarchy: Any,
    b: NDArray[np.float64],
    *,
    guess: NDArray[np.float64] | None,
    tol: float,
    maxiter: int,
) -> NDArray[np.float64]:
    """``hierarchy.solve(b, x0=guess, tol=tol, maxiter=maxiter, accel="cg")`` at about two
    thirds of its cost, its dot products summed by :func:`_dot`.

    PyAMG's conjugate gradients (``pyamg.krylov.cg``, criterion ``"rr"``: the residual's norm
    against ``tol`` times the right-hand side's) with its multigrid preconditioner, the same
    operations in the same order on every value the solution depends on, less the work whose
    result it discards: its preconditioner is a whole ``solve`` call that measures the
    residual before and after its V-cycle (two products with the fine matrix, unused), the
    last residual is preconditioned before the stopping test, and a zero start's residual is
    computed by a product with zero.  The captured Tutte system of igea Loop-subdivided twice
    (2.1M unknowns, 30 iterations to 1e-10): 8.4 s against 6.7 s a column; the transfer's
    (3 iterations): 1.10 s against 0.65 s.  With PyAMG's dot products (BLAS's) the solutions
    were PyAMG's bit for bit, with and without a start; with :func:`_dot`'s they are PyAMG's
    to about 1e-11, and the same on any machine.
    """
    a = hierarchy.levels[0].A
    if guess is None:
        x = np.zeros_like(b)
        r = b.copy()  # b - A·0, exactly
    else:
        x = np.array(guess, dtype=np.float64)
        r = b - a @ x
    z = _precondition(hierarchy, r)
    p = z.copy()
    rz = _dot(r, z)
    normb = float(np.sqrt(_dot(b, b)))
    stop = tol * (normb if normb != 0.0 else 1.0)
    if np.sqrt(_dot(r, r)) < stop:
        return x
    it = 0
    while True:
        ap = a @ p
        rz_old = rz
        pap = _dot(ap, p)
        if pap < 0.0:  # not positive definite: stop where PyAMG stops
            return x
        alpha = rz / pap
        x += alpha * p
        if it % 8 and it > 0:  # PyAMG's residual, recomputed every eighth step
            r -= alpha * ap
        else:
            r = b - a @ x
        if np.sqrt(_dot(r, r)) < stop or it + 1 == maxiter:
            return x
        z = _precondition(hierarchy, r)
        rz = _dot(r, z)
        if rz < 0.0:
            return x
        p *= rz / rz_old
        p += z
        it += 1


def _amg_solve(
    hierarchy: Any,
    rhs: NDArray[np.float64],
    *,
    guess: NDArray[np.float64] | None,
    tol: float,
    maxiter: int,
) -> NDArray[np.float64]:
    """Each column of ``rhs`` by AMG-preconditioned CG from ``guess`` (zero if None).

    Two columns at a time, the even ones in a second thread: a column's solve depends on its
    own right-hand side and start alone, so each gives the same bits as alone.  PyAMG's
    Gauss-Seidel holds the GIL but SciPy's sparse products, half a V-cycle's time, release it
    (the 2.1M Laplacian: 20 products 1.12 s one after the other, 0.67 s in two threads; 10
    Gauss-Seidel sweeps 0.58 s one after the other, 0.60 s in two threads); igea at 5M
    vertices, N = 256: 96.1 -> 78.1 s, the kept mode 93.2 -> 86.1 s, the same output files.
    The hierarchy is shared read-only; its coarsest solver (a pseudo-inverse PyAMG makes at
    its first call) is made before the threads start.
    """
    out = np.empty_like(rhs)

    def column(c: int) -> NDArray[np.float64]:
        x0 = None if guess is None else np.ascontiguousarray(guess[:, c])
        return _pcg(hierarchy, np.ascontiguousarray(rhs[:, c]), guess=x0, tol=tol, maxiter=maxiter)

    if rhs.shape[1] == 1:
        out[:, 0] = column(0)
        return out
    coarsest = hierarchy.levels[-1].A
    hierarchy.coarse_solver(coarsest, np.zeros(coarsest.shape[0]))
    k = rhs.shape[1]
    with beside(lambda: [column(c) for c in range(0, k, 2)]) as even:
        for c in range(1, k, 2):
            out[:, c] = column(c)
    for c, x in zip(range(0, k, 2), even.result(), strict=True):
        out[:, c] = x
    return out


def solve_with_fixed(
    quadratic: sp.spmatrix,
    fixed: NDArray[np.int64],
    values: NDArray[np.float64],
    *,
    guess: NDArray[np.float64] | None = None,
    tol: float = TOLERANCE,
    solver: str = "auto",
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
    solver : {"auto", "multigrid"}, optional
        "auto": the direct factorisation up to :data:`DIRECT_LIMIT` free unknowns, multigrid
        above; "multigrid": multigrid at every size (its cost is linear in the mesh; the
        direct one is faster below the limit, `scripts/bench_scale.py` measures both).

    Returns
    -------
    (n, c) float64 ndarray

    Examples
    --------
    >>> q = sp.csr_matrix(np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]))
    >>> solve_with_fixed(q, np.array([0, 2]), np.array([[0.0], [1.0]])).ravel().round(12).tolist()
    [0.0, 0.5, 1.0]
    """
    if solver not in ("auto", "multigrid"):
        raise ValueError(f"solver must be 'auto' or 'multigrid', got {solver!r}")
    n = quadratic.shape[0]
    fixed = np.asarray(fixed, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64)
    columns = values.shape[1]
    free = np.ones(n, dtype=bool)
    free[fixed] = False
    index = np.flatnonzero(free)
    q = sp.csr_matrix(quadratic)
    q_free = q[index]
    rhs = -np.asarray(q_free[:, fixed] @ values).reshape(len(index), columns)
    x = np.empty((n, columns))
    x[fixed] = values
    if len(index) == 0:
        return x
    system = q_free[:, index]
    del q, q_free  # at 5M vertices each copy is 0.4 GB, and the grid mode's peak is here
    if solver == "auto" and len(index) <= DIRECT_LIMIT:
        try:
            x[index] = _Cholesky(system).solve(rhs)
            return x
        except ArithmeticError:  # semi-definite (a free vertex on no edge): as libigl did
            return _igl_with_fixed(quadratic, fixed, values)
    start = None if guess is None else np.asarray(guess, dtype=np.float64)[index]
    x[index] = _amg_solve(_hierarchy(system), rhs, guess=start, tol=tol, maxiter=_MAXITER)
    return x


def _igl_with_fixed(
    quadratic: sp.spmatrix, fixed: NDArray[np.int64], values: NDArray[np.float64]
) -> NDArray[np.float64]:
    """libigl's ``min_quad_with_fixed`` (its factorisation copes with a semi-definite block)."""
    n = quadratic.shape[0]
    columns = values.shape[1]
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
            try:
                self._factor = _Cholesky(matrix)
            except ArithmeticError:  # not numerically definite: conjugate gradients cope
                self._hierarchy = _hierarchy(sp.csr_matrix(matrix))
        else:
            self._hierarchy = _hierarchy(sp.csr_matrix(matrix))

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        """``A⁻¹ rhs`` for ``rhs`` of shape (n, c)."""
        rhs = np.asarray(rhs, dtype=np.float64)
        if self._factor is not None:
            return self._factor.solve(rhs)
        return _amg_solve(self._hierarchy, rhs, guess=None, tol=self._tol, maxiter=self._maxiter)
