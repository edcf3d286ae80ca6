"""Attacks on the coordinates and the element order: pose, scale, order, formats, noise, crop.

What pipelines do to a file without smoothing or remeshing it.  ``similarity``,
``rotation``, ``scaling``, ``reorder``, ``noise``, ``float32`` and ``round_trip`` keep the
connectivity (up to the order, or the triangle soup of STL); blind extraction must survive
them exactly or nearly.  ``quantize`` and ``crop`` are the MEPP benchmark's definitions (Wang
et al., "A benchmark for 3D mesh watermarking", SMI 2010, doi:10.1109/SMI.2010.33).  NumPy only.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import check_mesh
from meshwm.attacks.params import Mesh, check_options
from meshwm.mesh.io import read_mesh, write_mesh

__all__ = [
    "crop",
    "float32",
    "mirror",
    "noise",
    "quantize",
    "reorder",
    "rotation",
    "round_trip",
    "scaling",
    "similarity",
]


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
    scale = check_options("similarity", scale=scale)["scale"]
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    s = float(np.exp(rng.uniform(np.log(0.01), np.log(100)))) if scale is None else float(scale)
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    t = rng.uniform(-10, 10, size=3) * diag
    return s * (v @ _random_rotation(rng).T) + t, np.asarray(faces, dtype=np.int64)


def mirror(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """A change of handedness: one axis negated (chosen by ``seed``), the faces turned over so
    that they face out again (what an engine's import of an asset from a right-handed tool
    does), then a random similarity as :func:`similarity`'s.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    >>> v2, f2 = mirror(v, [[0, 1, 2]], seed=1)
    >>> f2.tolist()
    [[2, 1, 0]]
    """
    flip = np.ones(3)
    flip[seed % 3] = -1.0
    v = np.asarray(vertices, dtype=np.float64) * flip
    return similarity(v, np.asarray(faces, dtype=np.int64)[:, ::-1].copy(), seed=seed)


def rotation(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """A random rotation about the centroid of the vertices (uniform on SO(3), from ``seed``).

    ``v' = (v - c) R^T + c`` with ``c`` the mean of the vertices and ``R`` drawn as in
    :func:`similarity` (QR of a Gaussian matrix, det +1).  Distances, the centroid and the
    orientation of the faces are kept; the faces are returned unchanged.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    >>> v2, f2 = rotation(v, [[0, 1, 2]], seed=3)
    >>> bool(np.allclose(v2.mean(axis=0), v.mean(axis=0))), f2.tolist()
    (True, [[0, 1, 2]])
    """
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    centre = v.mean(axis=0)
    return (v - centre) @ _random_rotation(rng).T + centre, np.asarray(faces, dtype=np.int64)


def scaling(vertices: NDArray, faces: NDArray, *, seed: int = 0, factor: float = 2.0) -> Mesh:
    """A uniform scale by ``factor`` (> 0) about the centroid of the vertices.

    ``v' = (v - c) · factor + c`` with ``c`` the mean of the vertices: every edge length is
    multiplied by ``factor``, the centroid stays where it is; the faces are returned
    unchanged.  ``seed`` is ignored.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 3.0, 0.0]])
    >>> scaling(v, [[0, 1, 2]], factor=0.5)[0].tolist()
    [[0.5, 0.5, 0.0], [1.5, 0.5, 0.0], [1.0, 2.0, 0.0]]
    """
    factor = check_options("scaling", factor=factor)["factor"]
    v = np.asarray(vertices, dtype=np.float64)
    centre = v.mean(axis=0)
    return (v - centre) * factor + centre, np.asarray(faces, dtype=np.int64)


def translation(
    vertices: NDArray, faces: NDArray, *, seed: int = 0, distance: float = 10.0
) -> Mesh:
    """A translation by ``distance`` bounding-box diagonals in a random direction (``seed``).

    The direction is uniform on the sphere (a normalised Gaussian vector); the faces are
    returned unchanged.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 4.0, 0.0]])
    >>> v2, _ = translation(v, [[0, 1, 2]], seed=1, distance=2.0)
    >>> float(np.linalg.norm(v2[0] - v[0]))  # 2 diagonals of length 5
    10.0
    """
    distance = check_options("translation", distance=distance)["distance"]
    v = np.asarray(vertices, dtype=np.float64)
    d = np.random.default_rng(seed).normal(size=3)
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    return v + distance * diag * d / np.linalg.norm(d), np.asarray(faces, dtype=np.int64)


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
    amplitude = check_options("noise", amplitude=amplitude)["amplitude"]
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
    """Write the mesh in a format (``.ply``, ``.obj``, ``.stl``, ``.off``, ``.glb``), read it back.

    STL keeps no indices and stores float32: it reads back as a triangle soup, three vertices
    per face (:func:`~meshwm.mesh.io.read_mesh` merges nothing).
    """
    suffix = check_options("round_trip", suffix=suffix)["suffix"]
    fd, path = tempfile.mkstemp(suffix=suffix)
    os.close(fd)
    try:
        os.remove(path)
        write_mesh(path, vertices, faces)
        return read_mesh(path)
    finally:
        if os.path.exists(path):
            os.remove(path)


def quantize(vertices: NDArray, faces: NDArray, *, seed: int = 0, bits: int = 9) -> Mesh:
    """Coordinate quantisation (MEPP): each axis snapped to ``2**bits`` levels of its range.

    Along each axis the bounding box [lo, hi] is divided into ``2**bits - 1`` equal steps and
    every coordinate is rounded to the nearest level, so at most ``2**bits`` distinct values
    remain per axis (``bits`` 7..16; MEPP uses 7 to 11).  An axis with zero extent is left as
    it is.  Faces are unchanged, even where vertices now coincide.  ``seed`` is ignored.
    """
    b = check_options("quantize", bits=bits)["bits"]
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
    frac = check_options("crop", fraction=fraction)["fraction"]
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
