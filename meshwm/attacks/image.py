"""The paper's section 5 attacks, done on the geometry image with MATLAB's kernels.

As the paper did them: on the three N×N coordinate matrices of the geometry image, each
filtered separately (``fspecial`` kernels, ``imfilter`` with replicate padding, ``imnoise``),
then written back into the mesh with its connectivity unchanged.  The mesh must be one meshwm
wrote: the grid is read from its connectivity by :func:`meshwm.gim.recover.recover_grid`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.ndimage import correlate
from scipy.sparse.csgraph import connected_components

from meshwm._validate import check_mesh
from meshwm.attacks.params import Mesh, check_options
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid

__all__ = [
    "fspecial_gaussian",
    "fspecial_laplacian",
    "fspecial_log",
    "gim_crop",
    "gim_gaussian",
    "gim_laplacian",
    "gim_log",
    "gim_noise",
    "gim_salt_pepper",
]


def fspecial_gaussian(hsize: int, sigma: float) -> NDArray[np.float64]:
    """MATLAB ``fspecial('gaussian', hsize, sigma)``: a sampled Gaussian, summing to 1.

    Examples
    --------
    >>> fspecial_gaussian(3, 0.5).round(4)
    array([[0.0113, 0.0838, 0.0113],
           [0.0838, 0.6193, 0.0838],
           [0.0113, 0.0838, 0.0113]])
    """
    r = (hsize - 1) / 2
    x, y = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1))
    h = np.exp(-(x * x + y * y) / (2 * sigma * sigma))
    h[h < np.finfo(np.float64).eps * h.max()] = 0
    return h / h.sum()


def fspecial_log(hsize: int, sigma: float) -> NDArray[np.float64]:
    """MATLAB ``fspecial('log', hsize, sigma)``: Laplacian of Gaussian, summing to 0.

    Examples
    --------
    >>> fspecial_log(5, 0.5)[2].round(4)
    array([ 0.0564,  0.7146, -4.9048,  0.7146,  0.0564])
    """
    r = (hsize - 1) / 2
    x, y = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1))
    s2 = sigma * sigma
    g = np.exp(-(x * x + y * y) / (2 * s2))
    g[g < np.finfo(np.float64).eps * g.max()] = 0
    g /= g.sum()
    h = g * (x * x + y * y - 2 * s2) / (s2 * s2)
    return h - h.sum() / h.size


def fspecial_laplacian(alpha: float) -> NDArray[np.float64]:
    """MATLAB ``fspecial('laplacian', alpha)``: 3×3 Laplacian, summing to 0.

    Examples
    --------
    >>> fspecial_laplacian(1.0)
    array([[ 0.5,  0. ,  0.5],
           [ 0. , -2. ,  0. ],
           [ 0.5,  0. ,  0.5]])
    """
    corner, edge = alpha / (alpha + 1), (1 - alpha) / (alpha + 1)
    return np.array(
        [[corner, edge, corner], [edge, -4 / (alpha + 1), edge], [corner, edge, corner]]
    )


def _filter(matrix: NDArray[np.float64], kernel: NDArray[np.float64]) -> NDArray[np.float64]:
    """MATLAB ``imfilter(matrix, kernel, 'replicate')``: correlation, border samples repeated."""
    return correlate(matrix, kernel, mode="nearest")


def _laplacian_smoothing(matrix: NDArray, kernel: NDArray) -> NDArray[np.float64]:
    """One full smoothing step with a Laplacian-type kernel (sum 0, negative centre c).

    ``x - (kernel ⋆ x) / c``: the centre weight becomes 0 and the others ``-h / c``, so each
    sample is replaced by the kernel-weighted average of its neighbours.
    """
    r = kernel.shape[0] // 2
    return matrix - _filter(matrix, kernel) / kernel[r, r]


def _grid_of(v: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.int64]:
    """(N, N) vertex index of each geometry-image sample of a meshwm mesh.

    The grid is the largest connected component (by faces); other components (meshwm passes
    them through) are left alone.
    """
    n = len(v)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    face_label = labels[f[:, 0]]
    main = f[face_label == np.argmax(np.bincount(face_label))]
    used = np.unique(main)
    local = np.full(n, -1, dtype=np.int64)
    local[used] = np.arange(len(used))
    try:
        grid = recover_grid(v[used], local[main])
    except GridError as exc:
        raise GridError(f"gim attacks need a mesh written by meshwm ({exc})") from None
    if np.any(grid.index < 0):
        raise GridError(
            f"gim attacks need a complete geometry image; {1 - grid.coverage:.1%} of the "
            "samples are missing (the mesh was cropped)"
        )
    return used[grid.index]


def _gim_attack(
    vertices: NDArray,
    faces: NDArray,
    attack: Callable[[NDArray[np.float64]], NDArray[np.float64]],
) -> Mesh:
    """Read the geometry image, apply ``attack`` to the (N, N, 3) image, write it back.

    A vertex shared by several samples (the two sides of a welded cut, a fold tip) takes the
    value of the first of them in row-major order.  Faces are returned unchanged.
    """
    v, f = check_mesh(vertices, faces)
    grid = _grid_of(v, f)
    out = attack(v[grid]).reshape(-1, 3)
    index = grid.ravel()
    _, first = np.unique(index, return_index=True)
    v[index[first]] = out[first]
    return v, f


def _per_channel(
    gim: NDArray[np.float64], channel: Callable[[NDArray[np.float64]], NDArray[np.float64]]
) -> NDArray[np.float64]:
    """Apply ``channel`` to x, y and z in turn (the paper's x1, x2, x3), each on its own."""
    return np.stack([channel(gim[..., k]) for k in range(3)], axis=-1)


def gim_gaussian(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, hsize: int = 3, sigma: float = 10.0
) -> Mesh:
    """Gaussian smoothing of the geometry image (paper: hsize 3 and 7, sigma 10).

    Each of x, y, z is filtered with MATLAB's ``fspecial('gaussian', hsize, sigma)``
    (:func:`fspecial_gaussian`; ``hsize`` odd, 3..31 samples; ``sigma`` in (0, 100] samples)
    by ``imfilter(..., 'replicate')``.  Replicate padding, not MATLAB's default zero padding:
    zeros would pull every border sample towards the origin of the coordinate system (the
    border of a geometry image is the cut seam, in the middle of the surface), an artefact
    that depends on where the model happens to sit.  ``seed`` is ignored.
    """
    o = check_options("gim_gaussian", hsize=hsize, sigma=sigma)
    kernel = fspecial_gaussian(o["hsize"], o["sigma"])
    return _gim_attack(vertices, faces, lambda g: _per_channel(g, lambda x: _filter(x, kernel)))


def gim_log(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, hsize: int = 5, sigma: float = 0.5
) -> Mesh:
    """LoG smoothing of the geometry image (paper: hsize 5, sigma 0.5).

    With ``h = fspecial('log', hsize, sigma)`` (:func:`fspecial_log`; ``hsize`` odd 3..31,
    ``sigma`` in (0, 10] samples) and ``c`` its (negative) centre value, each of x, y, z
    becomes ``x - imfilter(x, h, 'replicate') / c``: one full Laplacian smoothing step with
    the LoG's weights.  The paper calls this a smoothing filter; filtering the coordinates
    with ``h`` itself gives an edge map (values near 0) that is no model at all.  For
    (5, 0.5) every off-centre weight is positive, so each sample becomes a convex average of
    its 5×5 neighbours (centre weight 0).  ``seed`` is ignored.
    """
    o = check_options("gim_log", hsize=hsize, sigma=sigma)
    kernel = fspecial_log(o["hsize"], o["sigma"])
    return _gim_attack(
        vertices, faces, lambda g: _per_channel(g, lambda x: _laplacian_smoothing(x, kernel))
    )


def gim_laplacian(vertices: NDArray, faces: NDArray, *, seed: int = 0, alpha: float = 1.0) -> Mesh:
    """Laplacian smoothing of the geometry image (paper: alpha 1).

    With ``h = fspecial('laplacian', alpha)`` (:func:`fspecial_laplacian`; ``alpha`` in
    [0, 1], the weight of the diagonal neighbours) each of x, y, z becomes ``x -
    imfilter(x, h, 'replicate') / c``, ``c = -4 / (alpha + 1)`` the centre value: every sample
    is replaced by the average of its 8 neighbours weighted ``alpha`` (diagonal) and ``1 -
    alpha`` (edge), the umbrella step with λ = 1.  For alpha = 1, the mean of the 4 diagonal
    neighbours.  ``seed`` is ignored.
    """
    o = check_options("gim_laplacian", alpha=alpha)
    kernel = fspecial_laplacian(o["alpha"])
    return _gim_attack(
        vertices, faces, lambda g: _per_channel(g, lambda x: _laplacian_smoothing(x, kernel))
    )


def gim_salt_pepper(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, density: float = 0.05
) -> Mesh:
    """Salt & pepper noise on the geometry image (paper: density 0.05 and 0.10).

    MATLAB ``imnoise(x, 'salt & pepper', density)`` on each of x, y, z normalised to [0, 1]
    by its own minimum and maximum (``mat2gray``), mapped back: in each matrix independently,
    a sample becomes the matrix's minimum with probability ``density / 2`` and its maximum
    with probability ``density / 2`` (``density`` in (0, 1]).  A hit sample jumps to the
    bounding box along that axis: a spike.  Uniform draws from ``seed``, for x, then y, z.
    """
    d = check_options("gim_salt_pepper", density=density)["density"]
    rng = np.random.default_rng(seed)

    def channel(x: NDArray[np.float64]) -> NDArray[np.float64]:
        u = rng.random(x.shape)
        out = x.copy()
        out[u < d / 2] = x.min()
        out[(u >= d / 2) & (u < d)] = x.max()
        return out

    return _gim_attack(vertices, faces, lambda g: _per_channel(g, channel))


def gim_noise(vertices: NDArray, faces: NDArray, *, seed: int = 0, amplitude: float = 0.1) -> Mesh:
    """Random noise on the geometry image (paper: "random noise of 10 % amplitude", 0.1).

    Each of x, y, z gets ``amplitude · (max - min) · U(-1, 1)`` per sample, ``max - min`` the
    matrix's own range: noise of ``amplitude`` (in (0, 1]) on the matrix normalised to [0, 1]
    as ``mat2gray`` would, mapped back.  Zero-mean (MATLAB ``rand`` alone would also shift
    the model by amplitude / 2).  Uniform draws from ``seed``, for x, then y, z.
    """
    a = check_options("gim_noise", amplitude=amplitude)["amplitude"]
    rng = np.random.default_rng(seed)

    def channel(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return x + a * (x.max() - x.min()) * rng.uniform(-1.0, 1.0, size=x.shape)

    return _gim_attack(vertices, faces, lambda g: _per_channel(g, channel))


def gim_crop(vertices: NDArray, faces: NDArray, *, seed: int = 0, fraction: float = 0.09) -> Mesh:
    """Cropping of the geometry image (paper: 9 % and 16 %).

    A square block of ``s = round(sqrt(fraction) · N)`` samples a side (``fraction`` in
    (0, 1) of the samples: 9 % and 16 % are blocks of 0.3 N and 0.4 N), at a position drawn
    uniformly from ``seed``, loses its content: every sample in it takes the block's mean
    (x, y, z each).  The connectivity stays, so that part of the surface collapses to one
    point.  The mean, not MATLAB's black (0), so the attack does not depend on where the
    origin is: cropping commutes with rotation, translation and scaling.
    """
    frac = check_options("gim_crop", fraction=fraction)["fraction"]
    rng = np.random.default_rng(seed)

    def attack(gim: NDArray[np.float64]) -> NDArray[np.float64]:
        n = gim.shape[0]
        side = min(n, max(1, round(math.sqrt(frac) * n)))
        i, j = rng.integers(0, n - side + 1, size=2)
        out = gim.copy()
        block = out[i : i + side, j : j + side]
        block[...] = block.reshape(-1, 3).mean(axis=0)
        return out

    return _gim_attack(vertices, faces, attack)
