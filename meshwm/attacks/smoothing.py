"""Smoothing attacks: uniform Laplacian (MEPP), MeshLab's Laplacian and Taubin λ|μ.

``laplacian`` is the MEPP benchmark's definition (Wang et al., "A benchmark for 3D mesh
watermarking", SMI 2010, doi:10.1109/SMI.2010.33) with a sparse NumPy operator;
``meshlab_laplacian`` and ``taubin`` are MeshLab's filters (pymeshlab) with MeshLab's
defaults.  Vertices move, the faces are kept.
"""

from __future__ import annotations

from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks._meshlab import run_meshlab
from meshwm.attacks.params import Mesh, check_options
from meshwm.mesh.clean import uniform_smoothing_operator

__all__ = ["laplacian", "meshlab_laplacian", "taubin"]


def laplacian(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, lam: float = 0.1, iterations: int = 5
) -> Mesh:
    """Laplacian smoothing with uniform weights (MEPP): ``v += lam · (mean of neighbours - v)``.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seed : int
        Ignored (the attack is not random).
    lam : float
        Step λ of each iteration, in (0, 1] (MEPP: 0.1).
    iterations : int
        Number of steps, 1..1000 (MEPP: 5, 10, 30, 50).

    Notes
    -----
    All vertices move at once (Jacobi), ``iterations`` times.  A boundary vertex averages only
    its two (or more) neighbours along the boundary, so holes and borders are smoothed as
    polylines and not pulled into the surface; a vertex without edges stays where it is.
    """
    opts = check_options("laplacian", lam=lam, iterations=iterations)
    v, f = check_mesh(vertices, faces)
    step, moved = uniform_smoothing_operator(len(v), f)
    for _ in range(opts["iterations"]):
        v[moved] += opts["lam"] * ((step @ v)[moved] - v[moved])
    return v, f


def meshlab_laplacian(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 3
) -> Mesh:
    """MeshLab's Laplacian smoothing (``apply_coord_laplacian_smoothing``).

    ``iterations`` is its ``stepsmoothnum`` (1..1000, default 3, MeshLab's own default); the
    other options keep MeshLab's defaults: cotangent weights and 1D boundary smoothing.
    ``seed`` is ignored.
    """
    n = check_options("meshlab_laplacian", iterations=iterations)["iterations"]
    return run_meshlab(
        vertices, faces, lambda ms: ms.apply_coord_laplacian_smoothing(stepsmoothnum=n)
    )


def taubin(
    vertices: NDArray,
    faces: NDArray,
    *,
    seed: int = 0,
    lam: float = 0.5,
    mu: float = -0.53,
    iterations: int = 10,
) -> Mesh:
    """Taubin λ|μ smoothing (MeshLab ``apply_coord_taubin_smoothing``), shrinks little.

    Each iteration is a Laplacian step with ``lam`` (in (0, 1]) and one with ``mu`` (in
    [-1, 0)); ``iterations`` (1..1000) is MeshLab's ``stepsmoothnum``.  Defaults are MeshLab's:
    λ = 0.5, μ = -0.53, 10 steps.  ``seed`` is ignored.

    References
    ----------
    G. Taubin, "A signal processing approach to fair surface design", SIGGRAPH 1995,
    doi:10.1145/218380.218473.
    """
    o = check_options("taubin", lam=lam, mu=mu, iterations=iterations)
    return run_meshlab(
        vertices,
        faces,
        lambda ms: ms.apply_coord_taubin_smoothing(
            lambda_=o["lam"], mu=o["mu"], stepsmoothnum=o["iterations"]
        ),
    )
