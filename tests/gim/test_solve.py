"""meshwm.gim.solve: the multigrid path of large systems agrees with the direct one."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from _blas_threads import printed_under_blas_threads

from meshwm.gim import solve
from meshwm.gim.stable import stable_cut
from meshwm.gim.tutte import tutte_map


def test_a_tutte_map_by_multigrid_equals_the_direct_one(spot_mesh, monkeypatch):
    v, f = spot_mesh
    cut = stable_cut(v, f)
    label = np.empty_like(cut.order)
    label[cut.order] = np.arange(len(cut.order))
    rank = label[cut.mesh.origin]
    direct = tutte_map(cut.mesh.faces, rank)
    monkeypatch.setattr(solve, "DIRECT_LIMIT", 0)
    amg = tutte_map(cut.mesh.faces, rank)
    # Solved to the map's relative residual (1e-7): near the exact map, and still an
    # embedding (every triangle keeps its orientation: no fold).
    np.testing.assert_allclose(amg, direct, rtol=0, atol=2e-6)
    assert not np.array_equal(amg, direct)  # the multigrid path, not the direct one again
    a = amg[cut.mesh.faces]
    e1, e2 = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
    assert np.all(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0)
    np.testing.assert_array_equal(amg, tutte_map(cut.mesh.faces, rank))  # deterministic


@pytest.mark.parametrize("limit", [0, 10**9])
def test_spd_solver_solves(limit, monkeypatch):
    monkeypatch.setattr(solve, "DIRECT_LIMIT", limit)
    n = 400
    rng = np.random.default_rng(0)
    main = np.full(n, 2.5)
    off = -np.ones(n - 1)
    import scipy.sparse as sp

    matrix = sp.diags([off, main, off], [-1, 0, 1]).tocsr()
    rhs = rng.normal(size=(n, 3))
    x = solve.SpdSolver(matrix, tol=1e-12).solve(rhs)
    np.testing.assert_allclose(matrix @ x, rhs, atol=1e-9)


def test_a_pattern_factored_again_reuses_its_ordering_and_gives_the_same_bits(spot_mesh):
    # The stretch reweighting factors one pattern with new weights: the ordering found the
    # first time is reused, and the solution is the one a fresh analysis gives, bit for bit.
    import scipy.sparse as sp

    from meshwm.gim.transfer import uniform_laplacian

    v, f = spot_mesh
    n = len(v)
    lap = uniform_laplacian(f, n)
    rng = np.random.default_rng(2)
    rhs = rng.normal(size=(n, 2))
    solve._ORDERINGS.clear()
    first = solve._Cholesky(lap.T @ lap + sp.identity(n)).solve(rhs)
    assert len(solve._ORDERINGS) == 1
    for _ in range(3):
        weights = sp.diags(rng.uniform(0.5, 2.0, size=n))
        matrix = lap.T @ weights @ lap + sp.identity(n)
        again = solve._Cholesky(matrix).solve(rhs)  # the ordering reused
        assert len(solve._ORDERINGS) == 1
        solve._ORDERINGS.clear()
        fresh = solve._Cholesky(matrix).solve(rhs)
        np.testing.assert_array_equal(again, fresh)
        np.testing.assert_allclose(matrix @ again, rhs, atol=1e-9)
    assert not np.array_equal(first, again)


def test_solve_with_fixed_by_multigrid_at_any_size_agrees_with_the_direct_solve(spot_mesh):
    import igl

    v, f = spot_mesh
    q = -igl.cotmatrix(v, f)
    fixed = np.array([0, 100, 200, 300])
    values = np.eye(4)[:, :2]
    direct = solve.solve_with_fixed(q, fixed, values)
    multigrid = solve.solve_with_fixed(q, fixed, values, solver="multigrid")
    np.testing.assert_allclose(multigrid, direct, rtol=0, atol=1e-7)
    assert not np.array_equal(multigrid, direct)  # another solver, not the direct one again
    with pytest.raises(ValueError, match="solver"):
        solve.solve_with_fixed(q, fixed, values, solver="cholesky")


@pytest.mark.parametrize(("tol", "maxiter"), [(1e-10, 400), (1e-6, 3), (1e-300, 20)])
@pytest.mark.parametrize("start", [False, True])
def test_conjugate_gradients_are_pyamgs_iteration(spot_mesh, tol, maxiter, start, monkeypatch):
    # PyAMG's operations in PyAMG's order: with its dot products (BLAS's) the same solution
    # bit for bit; with meshwm's own (summed in a fixed order), the same to rounding.
    import scipy.sparse as sp

    from meshwm.gim.transfer import uniform_laplacian

    v, f = spot_mesh
    laplacian = uniform_laplacian(f, len(v))
    matrix = sp.csr_matrix(laplacian.T @ laplacian + 1e-3 * sp.identity(len(v)))
    rng = np.random.default_rng(7)
    rhs = rng.normal(size=(len(v), 2))
    guess = rng.normal(size=(len(v), 2)) if start else None
    hierarchy = solve._hierarchy(matrix)
    assert len(hierarchy.levels) > 2  # the V-cycle recurses
    got = solve._amg_solve(hierarchy, rhs, guess=guess, tol=tol, maxiter=maxiter)
    with monkeypatch.context() as m:
        m.setattr(solve, "_dot", lambda a, b: np.inner(a, b))
        as_pyamg = solve._amg_solve(hierarchy, rhs, guess=guess, tol=tol, maxiter=maxiter)
    for c in range(2):
        x0 = None if guess is None else np.ascontiguousarray(guess[:, c])
        b = np.ascontiguousarray(rhs[:, c])
        want = hierarchy.solve(b, x0=x0, tol=tol, maxiter=maxiter, accel="cg")
        np.testing.assert_array_equal(as_pyamg[:, c], want)
        np.testing.assert_allclose(got[:, c], want, rtol=0, atol=1e-9 * np.abs(want).max())
    if maxiter == 400:
        residual = np.linalg.norm(matrix @ got - rhs, axis=0) / np.linalg.norm(rhs, axis=0)
        assert residual.max() < 1e-9


def test_the_hierarchy_is_pyamgs_built_level_by_level_in_sorted_csr(spot_mesh):
    # Each level by PyAMG from the last one's matrix as sorted CSR: the same coarsening as
    # PyAMG's own hierarchy (whose coarse levels are unsorted 1×1 BSR), within a level or so,
    # and a preconditioner that converges as fast.
    import igl
    import pyamg
    import scipy.sparse as sp
    from pyamg.relaxation.smoothing import change_smoothers

    v, f = spot_mesh
    matrix = sp.csr_matrix(-igl.cotmatrix(v, f))[4:, 4:] + sp.identity(len(v) - 4) * 1e-9
    ours = solve._hierarchy(matrix)
    for level in ours.levels:
        for op in (level.A, getattr(level, "P", None), getattr(level, "R", None)):
            if op is not None:
                assert op.format == "csr" and op.has_sorted_indices
    sizes = [level.A.shape[0] for level in ours.levels]
    assert sizes == sorted(sizes, reverse=True) and sizes[-1] <= 10
    theirs = pyamg.smoothed_aggregation_solver(
        sp.csr_matrix(matrix),
        symmetry="symmetric",
        smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}),
    )
    # The same smoothers as ours: one sweep each way on the finest level, symmetric below.
    change_smoothers(theirs, *solve._smoothers(len(theirs.levels)))
    assert abs(len(ours.levels) - len(theirs.levels)) <= 1
    assert sizes[1] == theirs.levels[1].A.shape[0]  # the same first aggregation
    b = np.random.default_rng(1).normal(size=matrix.shape[0])
    counts = []
    for hierarchy in (ours, theirs):
        residuals: list[float] = []
        x = hierarchy.solve(b, tol=1e-10, accel="cg", residuals=residuals)
        assert np.linalg.norm(matrix @ x - b) <= 1e-9 * np.linalg.norm(b)
        counts.append(len(residuals))
    assert counts[0] <= counts[1] + 1


def test_columns_solved_two_at_a_time_give_each_columns_own_solution(spot_mesh, monkeypatch):
    # Three columns through a fresh hierarchy (its coarsest solver not yet made): two threads
    # share it, and each column is the one solved alone, bit for bit.
    import threading

    import scipy.sparse as sp

    from meshwm.gim.transfer import uniform_laplacian

    v, f = spot_mesh
    laplacian = uniform_laplacian(f, len(v))
    matrix = sp.csr_matrix(laplacian.T @ laplacian + 1e-3 * sp.identity(len(v)))
    rhs = np.random.default_rng(11).normal(size=(len(v), 3))
    alone = [
        solve._amg_solve(solve._hierarchy(matrix), rhs[:, [c]], guess=None, tol=1e-10, maxiter=400)
        for c in range(3)
    ]
    threads = set()
    pcg = solve._pcg

    def recording(*args, **kwargs):
        threads.add(threading.get_ident())
        return pcg(*args, **kwargs)

    monkeypatch.setattr(solve, "_pcg", recording)
    together = solve._amg_solve(solve._hierarchy(matrix), rhs, guess=None, tol=1e-10, maxiter=400)
    assert len(threads) == 2
    for c in range(3):
        np.testing.assert_array_equal(together[:, [c]], alone[c])


def test_the_hierarchy_without_a_strength_matrix_is_the_one_with_pyamgs_symmetric_strength(
    spot_mesh,
):
    # At theta = 0 PyAMG's symmetric strength keeps every entry of A, and the aggregation
    # reads only its pattern: the hierarchy built on A itself (no strength matrix, a copy of A
    # at the grid mode's peak) is PyAMG's default one, operator for operator.
    import igl
    import pyamg
    import scipy.sparse as sp

    v, f = spot_mesh
    matrix = sp.csr_array(-igl.cotmatrix(v, f))[4:, 4:] + sp.identity(len(v) - 4) * 1e-9
    matrix = sp.csr_array(matrix)
    matrix.sort_indices()
    ours = solve._hierarchy(matrix)
    theirs = pyamg.smoothed_aggregation_solver(
        matrix,
        symmetry="symmetric",
        smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}),
        max_levels=2,
        max_coarse=10,
    )
    for name in ("P", "R"):
        a = sp.csr_array(getattr(ours.levels[0], name))
        b = sp.csr_array(getattr(theirs.levels[0], name))
        b.sort_indices()
        for x, y in zip((a.data, a.indices, a.indptr), (b.data, b.indices, b.indptr), strict=True):
            np.testing.assert_array_equal(x, y)
    coarse = sp.csr_array(theirs.levels[1].A)
    coarse.sort_indices()
    np.testing.assert_array_equal(ours.levels[1].A.toarray(), coarse.toarray())
    np.testing.assert_array_equal(ours.levels[1].B, theirs.levels[1].B)


@pytest.mark.parametrize("post", ["backward", "forward"])
def test_the_v_cycle_is_a_symmetric_preconditioner(spot_mesh, post):
    # One forward sweep before the coarse correction and one backward sweep after it on the
    # finest level (symmetric sweeps below): the V-cycle M is symmetric, u·M(w) = w·M(u), as
    # conjugate gradients need.  Forward sweeps on both sides would not be (checked: the
    # same measure is 5.6e-4 there, 1.7e-17 here).
    import igl
    import scipy.sparse as sp
    from pyamg.relaxation.smoothing import change_smoothers

    v, f = spot_mesh
    matrix = sp.csr_matrix(-igl.cotmatrix(v, f))[4:, 4:] + sp.identity(len(v) - 4) * 1e-9
    hierarchy = solve._hierarchy(matrix)
    assert len(hierarchy.levels) > 2
    if post == "forward":  # the pre-smoothers on both sides
        pre, _ = solve._smoothers(len(hierarchy.levels))
        change_smoothers(hierarchy, pre, pre)
    rng = np.random.default_rng(5)
    gaps = []
    for _ in range(5):
        u, w = rng.normal(size=(2, matrix.shape[0]))
        mu, mw = solve._precondition(hierarchy, u), solve._precondition(hierarchy, w)
        gaps.append(abs(u @ mw - w @ mu) / (np.linalg.norm(u) * np.linalg.norm(mw)))
    if post == "backward":
        assert max(gaps) < 1e-12
    else:
        assert max(gaps) > 1e-6


_THREADS_PROBE = textwrap.dedent(
    """
    import hashlib, sys
    import numpy as np
    import scipy.sparse as sp
    sys.path.insert(0, sys.argv[1])
    from _fixtures_cutmap import bumpy_sphere
    from meshwm.gim import solve
    from meshwm.gim.transfer import uniform_laplacian
    v, f = bumpy_sphere(7)
    laplacian = uniform_laplacian(f, len(v))
    matrix = sp.csr_matrix(laplacian.T @ laplacian + 1e-3 * sp.identity(len(v)))
    rhs = np.random.default_rng(7).normal(size=(len(v), 1))
    x = solve._amg_solve(solve._hierarchy(matrix), rhs, guess=None, tol=1e-10, maxiter=30)
    print(hashlib.sha256(x.tobytes()).hexdigest())
    """
)


def test_the_multigrid_solution_is_the_same_whatever_blas_threads_the_machine_has():
    # BLAS splits a long dot product between its threads, each split rounding its own way:
    # the iterates depended on the machine's cores (a 2.1M-vertex embedding came out other
    # with one thread than with two).
    assert len(printed_under_blas_threads(_THREADS_PROBE)) == 1
