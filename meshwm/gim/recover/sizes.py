"""The grid sizes N to try: from the face count, or the ``size`` given."""

from __future__ import annotations

from meshwm._validate import check_square_pow2
from meshwm.errors import GridError

_MIN_SIZE = 16
_MAX_SIZE = 4096
_SEARCH_CAP = 2048  # largest N tried beyond the face-count N when no size is given
_SEARCH_FACTORS = (1, 2, 4)  # N, 2N and 4N of the face count


def _check_size(size: int) -> int:
    """``size`` as an int, checked: a power of two from _MIN_SIZE to _MAX_SIZE."""
    return check_square_pow2(size, name="size", low=_MIN_SIZE, high=_MAX_SIZE)


def _size_from_faces(n_faces: int) -> int:
    """The smallest N whose grid has at least ``n_faces`` faces (GridError beyond _MAX_SIZE)."""
    n = _MIN_SIZE
    while 2 * (n - 1) ** 2 < n_faces:
        n *= 2
        if n > _MAX_SIZE:
            raise GridError(f"{n_faces} faces is more than a {_MAX_SIZE}-grid has")
    return n


def _candidate_sizes(n_faces: int, n_vertices: int, size: int | None) -> list[int]:
    """N to try: ``size``, or the N the face count fits and its 2x and 4x (capped)."""
    if size is not None:
        n = _check_size(size)
        if 2 * (n - 1) ** 2 < n_faces:
            raise GridError(f"{n_faces} faces is more than a {n} x {n} grid has")
        return [n]
    n0 = _size_from_faces(n_faces)
    sizes = [n0 * f for f in _SEARCH_FACTORS if n0 * f <= max(n0, _SEARCH_CAP)]
    return [n for n in sizes if n * n >= n_vertices]


def _in_order_sizes(n_faces: int, size: int | None) -> list[int]:
    """N to try the fast path with: ``size``, or the N that all ``n_faces`` fit and half of it.

    Every face is counted: in a file as meshwm wrote it the grid comes first, other components
    after it.  More faces than any grid has: none (the components decide).
    """
    if size is not None:
        return [_check_size(size)]
    try:
        n = _size_from_faces(n_faces)
    except GridError:
        return []
    return [n, n // 2] if n > _MIN_SIZE else [n]
