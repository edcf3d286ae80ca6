"""Attacks on marked meshes: what pipelines and adversaries do to a file.

Every attack is a function ``attack(vertices, faces, *, seed=0, **options) -> (vertices,
faces)``: pure, seeded, deterministic; :data:`ATTACKS` maps names to them (a new attack is one
function plus one entry).  Definitions follow the MEPP 3D watermarking benchmark where it has
one (Wang et al., "A benchmark for 3D mesh watermarking", SMI 2010, doi:10.1109/SMI.2010.33).

This module holds the attacks that keep the connectivity (pose, order, file formats,
coordinate noise), which blind extraction must survive exactly or nearly.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .io import read_mesh, write_mesh

__all__ = ["ATTACKS", "apply_attack", "float32", "noise", "reorder", "round_trip", "similarity"]

Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]


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


def noise(vertices: NDArray, faces: NDArray, *, seed: int = 0, amplitude: float = 0.001) -> Mesh:
    """Additive uniform noise (MEPP): each coordinate += U(-a, a) · d̄.

    ``amplitude`` a is a fraction (0.001 = 0.1 %) of d̄, the mean distance of the vertices to
    their centroid.
    """
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, dtype=np.float64)
    mean_dist = float(np.mean(np.linalg.norm(v - v.mean(axis=0), axis=1)))
    return v + rng.uniform(-amplitude, amplitude, size=v.shape) * mean_dist, np.asarray(faces)


def float32(vertices: NDArray, faces: NDArray, *, seed: int = 0) -> Mesh:
    """Coordinates rounded to single precision (glTF, many engines)."""
    v = np.asarray(vertices, dtype=np.float32).astype(np.float64)
    return v, np.asarray(faces, dtype=np.int64)


def round_trip(vertices: NDArray, faces: NDArray, *, seed: int = 0, suffix: str = ".stl") -> Mesh:
    """Write the mesh in a format (``.ply``, ``.obj``, ``.stl``) and read it back.

    STL keeps no indices and stores float32: reading it back re-welds vertices by position.
    """
    fd, path = tempfile.mkstemp(suffix=suffix)
    os.close(fd)
    try:
        os.remove(path)
        write_mesh(path, vertices, faces)
        return read_mesh(path)
    finally:
        if os.path.exists(path):
            os.remove(path)


ATTACKS: dict[str, Callable[..., Mesh]] = {
    "similarity": similarity,
    "reorder": reorder,
    "noise": noise,
    "float32": float32,
    "round_trip": round_trip,
}


def apply_attack(name: str, vertices: NDArray, faces: NDArray, **options) -> Mesh:
    """Run the attack called ``name`` (a key of :data:`ATTACKS`).

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
    return attack(vertices, faces, **options)
