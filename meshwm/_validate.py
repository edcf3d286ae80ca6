"""Input checks shared by every stage (private).

Every check raises :class:`MeshError` (a :class:`ValueError`) with a one-line message that
names what was wrong, the value received and, where there is one, the fix.  The CLI turns any
``ValueError`` into a one-line error on stderr and exit code 2.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm._digest import freeze, is_frozen
from meshwm.errors import MeshError

__all__ = [
    "DEFAULT_MAX_FACES",
    "DEFAULT_SIZE",
    "SIZE_RANGE",
    "check_integer",
    "check_mesh",
    "check_square_pow2",
]

#: Default refusal limit on the number of faces read from a file or given as arrays.
DEFAULT_MAX_FACES = 5_000_000
#: Geometry-image sizes N meshwm writes: powers of two in this range (inclusive).
SIZE_RANGE = (64, 2048)
#: The default geometry-image size N.
DEFAULT_SIZE = 256


def check_integer(
    value: object, *, name: str, low: int | None = None, high: int | None = None
) -> int:
    """Check that ``value`` is an integer (not a bool) in ``[low, high]``; return it as ``int``.

    Raises :class:`TypeError` for a non-integer and :class:`ValueError` out of range, naming
    ``name`` and the value received.

    Examples
    --------
    >>> check_integer(np.int64(3), name="level", low=1, high=5)
    3
    >>> check_integer(0, name="level", low=1)
    Traceback (most recent call last):
    ...
    ValueError: level must be >= 1, got 0
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    number = int(value)
    if low is not None and high is not None and not low <= number <= high:
        raise ValueError(f"{name} must lie in {low}..{high}, got {number}")
    if low is not None and number < low:
        raise ValueError(f"{name} must be >= {low}, got {number}")
    if high is not None and number > high:
        raise ValueError(f"{name} must be <= {high}, got {number}")
    return number


def check_mesh(
    vertices: NDArray, faces: NDArray, *, max_faces: int = DEFAULT_MAX_FACES, frozen: bool = False
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
    frozen : bool, optional
        False (default): new arrays, the caller's to change.  True: read-only arrays
        (:func:`meshwm._digest.freeze`), and arrays that already are (C-ordered float64 and
        int64, read-only down to their memory) returned as they are: a pipeline that hands a
        mesh from stage to stage then checks it without copying it, and the digests its
        memoised steps key on are computed once (:func:`meshwm._digest.arrays_key`).

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
    # (With ``frozen``, arrays immutable already are checked below, not copied.)
    if not (frozen and is_frozen(v) and v.dtype == np.float64 and v.flags.c_contiguous):
        v = v.astype(np.float64, copy=True)
    if not (frozen and is_frozen(f) and f.dtype == np.int64 and f.flags.c_contiguous):
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
    if frozen:
        freeze(v, f)
    return v, f


def check_square_pow2(
    size: object, *, name: str = "size", low: int = SIZE_RANGE[0], high: int = SIZE_RANGE[1]
) -> int:
    """Check that ``size`` is a power of two in ``[low, high]`` and return it as ``int``."""
    size = check_integer(size, name=name)
    if size < low or size > high or size & (size - 1):
        raise ValueError(f"{name} must be a power of two between {low} and {high}, got {size}")
    return size
