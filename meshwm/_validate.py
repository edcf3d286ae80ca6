"""Input checks shared by every stage (private).

Every check raises :class:`MeshError` (a :class:`ValueError`) with a one-line message that
names what was wrong, the value received and, where there is one, the fix.  The CLI turns any
``ValueError`` into a one-line error on stderr and exit code 2.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["DEFAULT_MAX_FACES", "MeshError", "check_mesh", "check_square_pow2"]

#: Default refusal limit on the number of faces read from a file (issue #2).
DEFAULT_MAX_FACES = 5_000_000


class MeshError(ValueError):
    """A mesh (or mesh file) that meshwm cannot work with; the message is one line."""


def check_mesh(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Check and normalise a triangle mesh given as arrays.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Vertex positions.
    faces : (m, 3) array_like of int
        Triangles as indices into ``vertices``.
    max_faces : int, optional
        Refuse meshes with more faces than this.

    Returns
    -------
    vertices : (n, 3) float64 ndarray
    faces : (m, 3) int64 ndarray

    Raises
    ------
    MeshError
        Empty mesh, wrong shapes, NaN/inf coordinates, indices out of range or too many faces.
    """
    v = np.asarray(vertices)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise MeshError(f"vertices must have shape (n, 3), got {v.shape}")
    if f.size == 0:
        raise MeshError("mesh has no faces")
    if f.ndim != 2 or f.shape[1] != 3:
        raise MeshError(f"faces must be triangles with shape (m, 3), got {f.shape}")
    if len(f) > max_faces:
        raise MeshError(f"mesh has {len(f)} faces, more than the limit of {max_faces}")
    if not np.issubdtype(v.dtype, np.number) or np.iscomplexobj(v):
        raise MeshError(f"vertex coordinates must be real numbers, got dtype {v.dtype}")
    if not np.issubdtype(f.dtype, np.integer):
        if (
            np.issubdtype(f.dtype, np.floating)
            and np.all(np.isfinite(f))
            and np.all(f == np.round(f))
            and np.all(np.abs(f) < 2.0**62)
        ):
            f = f.astype(np.int64)
        else:
            raise MeshError(f"face indices must be integers, got dtype {f.dtype}")
    v = v.astype(np.float64, copy=True)
    f = f.astype(np.int64, copy=True)
    if len(v) == 0:
        raise MeshError("mesh has no vertices")
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise MeshError(
            f"{int(bad.sum())} vertices have NaN or infinite coordinates "
            f"(first: {int(np.argmax(bad))})"
        )
    lo, hi = int(f.min()), int(f.max())
    if lo < 0 or hi >= len(v):
        raise MeshError(f"face indices must lie in [0, {len(v) - 1}], found {lo}..{hi}")
    return v, f


def check_square_pow2(size: int, *, name: str = "size", low: int = 64, high: int = 2048) -> int:
    """Check that ``size`` is a power of two in ``[low, high]`` and return it as ``int``."""
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(size).__name__}")
    size = int(size)
    if size < low or size > high or size & (size - 1):
        raise ValueError(f"{name} must be a power of two between {low} and {high}, got {size}")
    return size
