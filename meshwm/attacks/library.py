"""Attacks on marked meshes: what pipelines and adversaries do to a file.

Every attack is a function ``attack(vertices, faces, *, seed=0, **options) -> (vertices,
faces)``: pure, seeded, deterministic; :data:`ATTACKS` maps names to them (a new attack is one
function plus one entry) and :data:`ATTACK_PARAMS` describes every option (type, default,
unit, allowed range), which the attacks check and the CLI parses.

Three families (docs/attacks.md has the full table and every choice made):

Connectivity kept
    ``similarity``, ``reorder``, ``noise``, ``float32``, ``round_trip``: pose, element order,
    file formats and coordinate noise, which blind extraction must survive exactly or nearly.
Mesh attacks
    ``laplacian``, ``meshlab_laplacian``, ``taubin``, ``quantize``, ``crop``, ``simplify``,
    ``subdivide_midpoint``, ``subdivide_loop``: definitions of the MEPP 3D watermarking
    benchmark (Wang et al., "A benchmark for 3D mesh watermarking", SMI 2010,
    doi:10.1109/SMI.2010.33), MeshLab filters (pymeshlab) where MeshLab has them.
Geometry-image attacks (``gim_`` prefix)
    The paper's section 5 attacks, done as the paper did them: on the three N×N coordinate
    matrices of the geometry image, each filtered separately, then written back into the
    mesh with its connectivity unchanged.  The mesh must be one meshwm wrote: the grid is read
    from its connectivity by :func:`meshwm.gim.recover.recover_grid`.
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymeshlab
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.ndimage import correlate
from scipy.sparse.csgraph import connected_components

from meshwm._validate import check_mesh
from meshwm.errors import GridError
from meshwm.gim.recover import recover_grid
from meshwm.mesh.clean import uniform_smoothing_operator
from meshwm.mesh.io import WRITE_SUFFIXES, read_mesh, write_mesh

__all__ = [
    "ATTACKS",
    "ATTACK_PARAMS",
    "AttackParam",
    "apply_attack",
    "crop",
    "float32",
    "fspecial_gaussian",
    "fspecial_laplacian",
    "fspecial_log",
    "gim_crop",
    "gim_gaussian",
    "gim_laplacian",
    "gim_log",
    "gim_noise",
    "gim_salt_pepper",
    "laplacian",
    "meshlab_laplacian",
    "noise",
    "quantize",
    "reorder",
    "round_trip",
    "similarity",
    "simplify",
    "subdivide_loop",
    "subdivide_midpoint",
    "taubin",
]

Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]


# --------------------------------------------------------------------------------------------
# Parameter descriptions
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AttackParam:
    """One option of an attack: its type, default, meaning (with unit) and allowed values.

    Attributes
    ----------
    name : str
        Keyword name (and ``--name`` on the command line).
    type : type
        ``int``, ``float`` or ``str``.
    default : int, float, str or None
        Value used when the option is not given (``None``: see ``meaning``).
    meaning : str
        What the value means, with its unit.
    low, high : float, optional
        Bounds of the allowed range (``None``: unbounded).
    open_low, open_high : bool
        The bound itself is not allowed.
    choices : tuple of str, optional
        The allowed strings (``type`` is ``str``).
    odd : bool
        Only odd integers are allowed.
    """

    name: str
    type: type
    default: Any
    meaning: str
    low: float | None = None
    high: float | None = None
    open_low: bool = False
    open_high: bool = False
    choices: tuple[str, ...] | None = None
    odd: bool = False

    @property
    def allowed(self) -> str:
        """The allowed values in words, e.g. ``'a number in (0, 1]'``."""
        if self.choices is not None:
            return f"one of {', '.join(self.choices)}"
        what = {int: "an odd integer" if self.odd else "an integer", float: "a number"}[self.type]
        if self.type is int and self.low is not None and self.high is not None:
            return f"{what} in {self.low:g}..{self.high:g}"
        if self.low is not None and self.high is not None:
            left = "(" if self.open_low else "["
            right = ")" if self.open_high else "]"
            return f"{what} in {left}{self.low:g}, {self.high:g}{right}"
        if self.low is not None:
            return f"{what} {'>' if self.open_low else '>='} {self.low:g}"
        return what

    def check(self, value: Any, attack: str) -> Any:
        """Return ``value`` as this parameter's type, or raise.

        Raises
        ------
        TypeError
            Wrong type (``bool`` is not an integer here).
        ValueError
            Outside the allowed range; the message names the attack, the parameter, the
            allowed values and the value received.
        """
        if value is None and self.default is None:
            return None
        expected = {int: "an integer", float: "a number", str: "a string"}[self.type]
        if self.type is str:
            ok_type = isinstance(value, str)
        elif self.type is int:
            ok_type = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        else:
            ok_type = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                value, bool
            )
        if not ok_type:
            raise TypeError(f"{attack}: {self.name} must be {expected}, got {type(value).__name__}")
        value = self.type(value)
        if self._in_range(value):
            return value
        raise ValueError(f"{attack}: {self.name} must be {self.allowed}, got {value!r}")

    def _in_range(self, value: Any) -> bool:
        if self.choices is not None:
            return value in self.choices
        if self.type is float and not math.isfinite(value):
            return False
        if self.odd and value % 2 == 0:
            return False
        if self.low is not None and (value <= self.low if self.open_low else value < self.low):
            return False
        return not (
            self.high is not None and (value >= self.high if self.open_high else value > self.high)
        )

    def parse(self, text: str, attack: str) -> Any:
        """Convert command-line text to a checked value (``ValueError`` if it is not one)."""
        if self.type is str:
            return self.check(text, attack)
        try:
            value = self.type(text)
        except ValueError:
            raise ValueError(
                f"{attack}: {self.name} must be {self.allowed}, got {text!r}"
            ) from None
        return self.check(value, attack)


def _check(attack: str, **values: Any) -> dict[str, Any]:
    """Check an attack's options against :data:`ATTACK_PARAMS`; the converted values."""
    spec = {p.name: p for p in ATTACK_PARAMS[attack]}
    return {name: spec[name].check(value, attack) for name, value in values.items()}


# --------------------------------------------------------------------------------------------
# Connectivity kept: pose, order, formats, noise
# --------------------------------------------------------------------------------------------


def _random_rotation(rng: np.random.Generator) -> NDArray[np.float64]:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def similarity(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, scale: float | None = None
) -> Mesh:
    """A random rotation, a translation (up to 10 bounding-box diagonals) and a uniform scale.

    ``scale`` default: log-uniform in [0.01, 100].
    """
    scale = _check("similarity", scale=scale)["scale"]
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    s = float(np.exp(rng.uniform(np.log(0.01), np.log(100)))) if scale is None else float(scale)
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    t = rng.uniform(-10, 10, size=3) * diag
    return s * (v @ _random_rotation(rng).T) + t, np.asarray(faces, dtype=np.int64)


def reorder(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """Random permutation of the vertices, of the faces, and a cyclic shift within each face."""
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    perm = rng.permutation(len(v))
    inverse = np.argsort(perm)
    f = inverse[f][rng.permutation(len(f))]
    shift = rng.integers(0, 3, size=len(f))
    f = np.take_along_axis(f, (np.arange(3)[None, :] + shift[:, None]) % 3, axis=1)
    return v[perm], f


def _mean_centroid_distance(v: NDArray[np.float64]) -> float:
    """d̄ of the MEPP benchmark: the mean distance of the vertices to their centroid."""
    return float(np.mean(np.linalg.norm(v - v.mean(axis=0), axis=1)))


def noise(vertices: NDArray, faces: NDArray, *, seed: int = 0, amplitude: float = 0.001) -> Mesh:
    """Additive uniform noise (MEPP): each coordinate += U(-a, a) · d̄.

    ``amplitude`` a is a fraction (0.001 = 0.1 %) of d̄, the mean distance of the vertices to
    their centroid.
    """
    amplitude = _check("noise", amplitude=amplitude)["amplitude"]
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    mean_dist = _mean_centroid_distance(v)
    noisy = v + rng.uniform(-amplitude, amplitude, size=v.shape) * mean_dist
    return noisy, np.asarray(faces, dtype=np.int64)


def float32(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """Coordinates rounded to single precision (glTF, many engines)."""
    v = np.asarray(vertices, dtype=np.float32).astype(np.float64)
    return v, np.asarray(faces, dtype=np.int64)


def round_trip(vertices: NDArray, faces: NDArray, *, seed: int = 0, suffix: str = ".stl") -> Mesh:
    """Write the mesh in a format (``.ply``, ``.obj``, ``.stl``) and read it back.

    STL keeps no indices and stores float32: it reads back as a triangle soup, three vertices
    per face (:func:`~meshwm.mesh.io.read_mesh` merges nothing).
    """
    suffix = _check("round_trip", suffix=suffix)["suffix"]
    fd, path = tempfile.mkstemp(suffix=suffix)
    os.close(fd)
    try:
        os.remove(path)
        write_mesh(path, vertices, faces)
        return read_mesh(path)
    finally:
        if os.path.exists(path):
            os.remove(path)


# --------------------------------------------------------------------------------------------
# Mesh attacks (MEPP benchmark, MeshLab filters)
# --------------------------------------------------------------------------------------------


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
    opts = _check("laplacian", lam=lam, iterations=iterations)
    v, f = check_mesh(vertices, faces)
    step, moved = uniform_smoothing_operator(len(v), f)
    for _ in range(opts["iterations"]):
        v[moved] += opts["lam"] * ((step @ v)[moved] - v[moved])
    return v, f


def _meshlab(vertices: NDArray, faces: NDArray, apply: Callable[[pymeshlab.MeshSet], None]) -> Mesh:
    v, f = check_mesh(vertices, faces)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f.astype(np.int32)))
    apply(ms)
    m = ms.current_mesh()
    return (
        np.array(m.vertex_matrix(), dtype=np.float64),
        np.array(m.face_matrix(), dtype=np.int64),
    )


def meshlab_laplacian(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 3
) -> Mesh:
    """MeshLab's Laplacian smoothing (``apply_coord_laplacian_smoothing``).

    ``iterations`` is its ``stepsmoothnum`` (1..1000, default 3, MeshLab's own default); the
    other options keep MeshLab's defaults: cotangent weights and 1D boundary smoothing.
    ``seed`` is ignored.
    """
    n = _check("meshlab_laplacian", iterations=iterations)["iterations"]
    return _meshlab(vertices, faces, lambda ms: ms.apply_coord_laplacian_smoothing(stepsmoothnum=n))


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
    o = _check("taubin", lam=lam, mu=mu, iterations=iterations)
    return _meshlab(
        vertices,
        faces,
        lambda ms: ms.apply_coord_taubin_smoothing(
            lambda_=o["lam"], mu=o["mu"], stepsmoothnum=o["iterations"]
        ),
    )


def quantize(vertices: NDArray, faces: NDArray, *, seed: int = 0, bits: int = 9) -> Mesh:
    """Coordinate quantisation (MEPP): each axis snapped to ``2**bits`` levels of its range.

    Along each axis the bounding box [lo, hi] is divided into ``2**bits - 1`` equal steps and
    every coordinate is rounded to the nearest level, so at most ``2**bits`` distinct values
    remain per axis (``bits`` 7..16; MEPP uses 7 to 11).  An axis with zero extent is left as
    it is.  Faces are unchanged, even where vertices now coincide.  ``seed`` is ignored.
    """
    b = _check("quantize", bits=bits)["bits"]
    v, f = check_mesh(vertices, faces)
    lo, hi = v.min(axis=0), v.max(axis=0)
    extent = hi - lo
    levels = 2**b - 1
    safe = np.where(extent > 0, extent, 1.0)
    q = lo + np.round((v - lo) / safe * levels) / levels * safe
    return np.where(extent > 0, q, v), f


def _face_areas(v: NDArray[np.float64], f: NDArray[np.int64]) -> NDArray[np.float64]:
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def _drop_unreferenced(v: NDArray[np.float64], f: NDArray[np.int64]) -> Mesh:
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return v[used], remap[f]


def crop(vertices: NDArray, faces: NDArray, *, seed: int = 0, fraction: float = 0.1) -> Mesh:
    """Cut off ``fraction`` of the surface area with a random plane (MEPP: 10, 30, 50 %).

    The plane's normal is uniform on the sphere (from ``seed``).  A face is removed when its
    centroid lies on the positive side; the offset is placed so that the removed faces' area
    is as close as possible to ``fraction`` (in (0, 1)) of the total area: faces are sorted by
    the height of their centroid along the normal and the cut goes between two consecutive
    heights (the exact answer that a bisection on the offset converges to).  Removed area
    differs from the target by less than one face.  Vertices no face uses any more are dropped;
    the others keep their order.
    """
    frac = _check("crop", fraction=fraction)["fraction"]
    rng = np.random.default_rng(seed)
    v, f = check_mesh(vertices, faces)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    height = v[f].mean(axis=1) @ normal
    area = _face_areas(v, f)
    order = np.argsort(-height, kind="stable")
    removed = np.concatenate([[0.0], np.cumsum(area[order])])  # area above each cut position
    k = int(np.argmin(np.abs(removed - frac * removed[-1])))
    k = min(k, len(f) - 1)  # keep at least one face
    sorted_heights = height[order]
    if k == 0:
        offset = sorted_heights[0]
    else:
        offset = 0.5 * (sorted_heights[k - 1] + sorted_heights[k])
    keep = height <= offset if k else np.ones(len(f), dtype=bool)
    return _drop_unreferenced(v, f[keep])


def simplify(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, keep_fraction: float = 0.5
) -> Mesh:
    """Quadric edge-collapse simplification to ``keep_fraction`` of the faces (MEPP: 70/50/10 %).

    MeshLab ``meshing_decimation_quadric_edge_collapse`` with ``targetfacenum =
    round(keep_fraction · faces)`` (``keep_fraction`` in (0, 1)) and these options:
    ``preserveboundary=True`` (``boundaryweight=1``), ``preservenormal=True`` (no face flips),
    ``preservetopology=True`` (no genus change), ``optimalplacement=True``,
    ``planarquadric=True`` (better on flat regions), ``qualitythr=0.3`` and
    ``autoclean=True``, i.e. MeshLab's defaults plus the three ``preserve*`` options.  The
    result has the target face count up to a face or two.  ``seed`` is ignored.
    """
    keep = _check("simplify", keep_fraction=keep_fraction)["keep_fraction"]
    target = max(1, round(keep * len(np.asarray(faces))))
    return _meshlab(
        vertices,
        faces,
        lambda ms: ms.meshing_decimation_quadric_edge_collapse(
            targetfacenum=target,
            qualitythr=0.3,
            preserveboundary=True,
            boundaryweight=1.0,
            preservenormal=True,
            preservetopology=True,
            optimalplacement=True,
            planarquadric=True,
            autoclean=True,
        ),
    )


def subdivide_midpoint(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 1
) -> Mesh:
    """Midpoint subdivision (MeshLab ``meshing_surface_subdivision_midpoint``).

    Every edge is split at its midpoint (edge-length threshold 0, absolute), so each
    iteration (``iterations`` 1..3) multiplies the face count by 4; no vertex moves.
    ``seed`` is ignored.
    """
    n = _check("subdivide_midpoint", iterations=iterations)["iterations"]
    return _meshlab(
        vertices,
        faces,
        lambda ms: ms.meshing_surface_subdivision_midpoint(
            iterations=n, threshold=pymeshlab.PureValue(0.0)
        ),
    )


def subdivide_loop(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, iterations: int = 1
) -> Mesh:
    """Loop subdivision (MeshLab ``meshing_surface_subdivision_loop``, Loop's weights).

    Every edge is split (threshold 0, absolute) and all vertices move by Loop's rules, so
    each iteration (``iterations`` 1..3) multiplies the face count by 4.  ``seed`` is ignored.
    """
    n = _check("subdivide_loop", iterations=iterations)["iterations"]
    return _meshlab(
        vertices,
        faces,
        lambda ms: ms.meshing_surface_subdivision_loop(
            loopweight="Loop", iterations=n, threshold=pymeshlab.PureValue(0.0)
        ),
    )


# --------------------------------------------------------------------------------------------
# The paper's attacks, on the geometry image
# --------------------------------------------------------------------------------------------


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
    o = _check("gim_gaussian", hsize=hsize, sigma=sigma)
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
    o = _check("gim_log", hsize=hsize, sigma=sigma)
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
    o = _check("gim_laplacian", alpha=alpha)
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
    d = _check("gim_salt_pepper", density=density)["density"]
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
    a = _check("gim_noise", amplitude=amplitude)["amplitude"]
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
    frac = _check("gim_crop", fraction=fraction)["fraction"]
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


# --------------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------------


ATTACKS: dict[str, Callable[..., Mesh]] = {
    "similarity": similarity,
    "reorder": reorder,
    "noise": noise,
    "float32": float32,
    "round_trip": round_trip,
    "laplacian": laplacian,
    "meshlab_laplacian": meshlab_laplacian,
    "taubin": taubin,
    "quantize": quantize,
    "crop": crop,
    "simplify": simplify,
    "subdivide_midpoint": subdivide_midpoint,
    "subdivide_loop": subdivide_loop,
    "gim_gaussian": gim_gaussian,
    "gim_log": gim_log,
    "gim_laplacian": gim_laplacian,
    "gim_salt_pepper": gim_salt_pepper,
    "gim_noise": gim_noise,
    "gim_crop": gim_crop,
}

_ITERATIONS = "number of iterations"

#: The options of every attack in :data:`ATTACKS` (``seed`` aside: every attack takes it).
ATTACK_PARAMS: dict[str, tuple[AttackParam, ...]] = {
    "similarity": (
        AttackParam(
            "scale",
            float,
            None,
            "uniform scale factor (default: log-uniform in [0.01, 100] from the seed)",
            low=0,
            open_low=True,
        ),
    ),
    "reorder": (),
    "noise": (
        AttackParam(
            "amplitude",
            float,
            0.001,
            "noise bound as a fraction of d̄, the mean vertex-to-centroid distance",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "float32": (),
    "round_trip": (
        AttackParam("suffix", str, ".stl", "file format written and read", choices=WRITE_SUFFIXES),
    ),
    "laplacian": (
        AttackParam("lam", float, 0.1, "step λ per iteration", low=0, high=1, open_low=True),
        AttackParam("iterations", int, 5, _ITERATIONS, low=1, high=1000),
    ),
    "meshlab_laplacian": (
        AttackParam("iterations", int, 3, "MeshLab stepsmoothnum", low=1, high=1000),
    ),
    "taubin": (
        AttackParam("lam", float, 0.5, "shrinking step λ", low=0, high=1, open_low=True),
        AttackParam("mu", float, -0.53, "inflating step μ", low=-1, high=0, open_high=True),
        AttackParam("iterations", int, 10, "MeshLab stepsmoothnum (λ|μ pairs)", low=1, high=1000),
    ),
    "quantize": (
        AttackParam("bits", int, 9, "bits per bounding-box axis (2**bits levels)", low=7, high=16),
    ),
    "crop": (
        AttackParam(
            "fraction",
            float,
            0.1,
            "fraction of the surface area removed",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
    "simplify": (
        AttackParam(
            "keep_fraction",
            float,
            0.5,
            "fraction of the faces kept",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
    "subdivide_midpoint": (AttackParam("iterations", int, 1, _ITERATIONS, low=1, high=3),),
    "subdivide_loop": (AttackParam("iterations", int, 1, _ITERATIONS, low=1, high=3),),
    "gim_gaussian": (
        AttackParam("hsize", int, 3, "kernel side, samples", low=3, high=31, odd=True),
        AttackParam(
            "sigma",
            float,
            10.0,
            "Gaussian standard deviation, samples",
            low=0,
            high=100,
            open_low=True,
        ),
    ),
    "gim_log": (
        AttackParam("hsize", int, 5, "kernel side, samples", low=3, high=31, odd=True),
        AttackParam(
            "sigma",
            float,
            0.5,
            "Gaussian standard deviation, samples",
            low=0,
            high=10,
            open_low=True,
        ),
    ),
    "gim_laplacian": (
        AttackParam(
            "alpha", float, 1.0, "weight of the diagonal neighbours (fspecial)", low=0, high=1
        ),
    ),
    "gim_salt_pepper": (
        AttackParam(
            "density",
            float,
            0.05,
            "probability that a sample of a matrix is hit (half min, half max)",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "gim_noise": (
        AttackParam(
            "amplitude",
            float,
            0.1,
            "noise bound as a fraction of each matrix's range (max - min)",
            low=0,
            high=1,
            open_low=True,
        ),
    ),
    "gim_crop": (
        AttackParam(
            "fraction",
            float,
            0.09,
            "fraction of the geometry-image samples in the cropped square",
            low=0,
            high=1,
            open_low=True,
            open_high=True,
        ),
    ),
}


def apply_attack(name: str, vertices: NDArray, faces: NDArray, **options) -> Mesh:
    """Run the attack called ``name`` (a key of :data:`ATTACKS`).

    Parameters
    ----------
    name : str
        The attack.
    vertices, faces : array_like
        The mesh.
    **options
        ``seed`` and the attack's options (:data:`ATTACK_PARAMS`).

    Raises
    ------
    ValueError
        Unknown attack or option (the message lists the valid ones), or a bad option value.

    Examples
    --------
    >>> v = np.eye(3); f = np.array([[0, 1, 2]])
    >>> v2, f2 = apply_attack("float32", v, f)
    >>> bool(np.array_equal(v2, v))
    True
    """
    try:
        attack = ATTACKS[name]
    except KeyError:
        raise ValueError(f"unknown attack {name!r}; valid: {', '.join(sorted(ATTACKS))}") from None
    valid = ["seed", *(p.name for p in ATTACK_PARAMS[name])]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(
            f"{name}: unknown option {', '.join(map(repr, unknown))}; valid: {', '.join(valid)}"
        )
    return attack(vertices, faces, **options)
