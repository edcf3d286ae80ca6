"""Arnold scrambling of the square mark image (section 2 and section 3, step 5 of the paper).

Before it is embedded, the binary mark is scrambled with Arnold's cat map "for key times", so
that a local loss of coefficients (cropping) becomes scattered bit errors instead of a hole in
the logo.  The map moves the pixel at row ``P``, column ``Q`` of an N×N image to

.. math::

    \\begin{pmatrix} P' \\\\ Q' \\end{pmatrix} =
    \\begin{pmatrix} 1 & 1 \\\\ 1 & 2 \\end{pmatrix}
    \\begin{pmatrix} P \\\\ Q \\end{pmatrix} \\bmod N .

Its matrix has determinant 1, so it is invertible modulo every N; the inverse map uses
:math:`\\begin{pmatrix} 2 & -1 \\\\ -1 & 1 \\end{pmatrix}`.  Everything here is integer
arithmetic on indices: the result depends only on the image, N and the number of iterations,
never on a random stream or the platform.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", sections 2 and 3.
.. [2] F. J. Dyson, H. Falk, "Period of a discrete cat mapping", The American Mathematical
   Monthly 99(7), 603-614, 1992, doi:10.2307/2324989.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["arnold_period", "arnold_scramble", "arnold_unscramble"]

#: The paper's cat map, acting on (row, column) index pairs.
_FORWARD = ((1, 1), (1, 2))
#: Its inverse (determinant 1, so this is the inverse modulo every N).
_INVERSE = ((2, -1), (-1, 1))

_Matrix = tuple[tuple[int, int], tuple[int, int]]


def _matmul_mod(a: _Matrix, b: _Matrix, n: int) -> _Matrix:
    """Product of two 2×2 integer matrices modulo ``n`` (Python ints: no overflow)."""
    return (
        ((a[0][0] * b[0][0] + a[0][1] * b[1][0]) % n, (a[0][0] * b[0][1] + a[0][1] * b[1][1]) % n),
        ((a[1][0] * b[0][0] + a[1][1] * b[1][0]) % n, (a[1][0] * b[0][1] + a[1][1] * b[1][1]) % n),
    )


def _matpow_mod(matrix: _Matrix, power: int, n: int) -> _Matrix:
    """``matrix ** power`` modulo ``n`` by repeated squaring: the map iterated ``power`` times."""
    result: _Matrix = ((1 % n, 0), (0, 1 % n))
    base = _matmul_mod(matrix, ((1, 0), (0, 1)), n)
    while power:
        if power & 1:
            result = _matmul_mod(base, result, n)
        base = _matmul_mod(base, base, n)
        power >>= 1
    return result


def _check_size(n: object) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an integer, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    return int(n)


def _check_iterations(iterations: object) -> int:
    if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)):
        raise TypeError(f"iterations must be an integer, got {type(iterations).__name__}")
    if iterations < 0:
        raise ValueError(
            f"iterations must be >= 0, got {iterations}; use arnold_unscramble to invert"
        )
    return int(iterations)


def _check_image(image: NDArray) -> NDArray:
    array = np.asarray(image)
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.size == 0:
        raise ValueError(f"image must be a non-empty square N×N array, got shape {array.shape}")
    return array


@lru_cache(maxsize=256)
def _period(n: int) -> int:
    identity = ((1 % n, 0), (0, 1 % n))
    power = _matmul_mod(_FORWARD, ((1, 0), (0, 1)), n)
    k = 1
    while power != identity:
        power = _matmul_mod(_FORWARD, power, n)
        k += 1
    return k


def arnold_period(n: int) -> int:
    """Period of the Arnold cat map on an ``n``×``n`` image.

    Parameters
    ----------
    n : int
        Side of the square image, at least 1.

    Returns
    -------
    int
        The smallest ``k > 0`` such that iterating the map ``k`` times is the identity on
        every ``n``×``n`` image.

    Raises
    ------
    TypeError
        ``n`` is not an integer.
    ValueError
        ``n`` is less than 1.

    Notes
    -----
    Computed from the 2×2 matrix: its powers modulo ``n`` are formed one by one until the
    identity comes back, at most ``3n`` steps [2]_ (never from the image).  The period is
    short: 3 for ``n = 4``, 24 for 32, 48 for 64, 192 for 256, and ``3n`` exactly when
    ``n = 2·5^j``.  So the paper's key (the number of iterations, 5 in its experiments) has
    only ``arnold_period(n)`` distinct values and is no secret by itself; the watermark stage
    adds a keyed permutation on top.  Results are cached.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on
       multi-resolution representation and fuzzy logic", section 2.
    .. [2] F. J. Dyson, H. Falk, "Period of a discrete cat mapping", Amer. Math. Monthly
       99(7), 1992, doi:10.2307/2324989.

    Examples
    --------
    >>> from meshwm.message.scramble import arnold_period
    >>> [arnold_period(n) for n in (4, 8, 16, 32, 64)]
    [3, 6, 12, 24, 48]
    """
    return _period(_check_size(n))


def _permute(image: NDArray, matrix: _Matrix, iterations: int) -> NDArray:
    """Scatter ``image[P, Q]`` to ``(matrix ** iterations) @ (P, Q) mod N``, as a new array."""
    array = _check_image(image)
    iterations = _check_iterations(iterations)
    n = array.shape[0]
    (a, b), (c, d) = _matpow_mod(matrix, iterations % _period(n), n)
    p = np.arange(n, dtype=np.int64)[:, None]
    q = np.arange(n, dtype=np.int64)[None, :]
    out = np.empty_like(array, order="C")
    out[(a * p + b * q) % n, (c * p + d * q) % n] = array
    return out


def arnold_scramble(image: NDArray, *, iterations: int) -> NDArray:
    """Scramble a square image with Arnold's cat map, applied ``iterations`` times.

    Parameters
    ----------
    image : (N, N) array_like
        The image (any dtype), e.g. the binary mark as ``uint8`` 0/1.  Not modified.
    iterations : int
        How many times the map is applied (the paper's key; 5 in its experiments), >= 0.

    Returns
    -------
    (N, N) ndarray
        A new array of the same dtype: the pixel at ``(P, Q)`` moved to
        ``((P + Q) mod N, (P + 2Q) mod N)``, ``iterations`` times over.

    Raises
    ------
    ValueError
        ``image`` is not a non-empty square 2-D array, or ``iterations`` is negative.
    TypeError
        ``iterations`` is not an integer.

    See Also
    --------
    arnold_unscramble : the exact inverse.
    arnold_period : iterations after which the image comes back.

    Notes
    -----
    ``P`` is the row and ``Q`` the column index.  The ``iterations``-fold map is one matrix
    power modulo N (the map composed with itself), and ``iterations`` is first reduced
    modulo :func:`arnold_period`, so the cost is one gather of N² pixels whatever the count.
    ``iterations`` and ``iterations + arnold_period(N)`` give the same result, and a multiple
    of the period gives the image back: the scrambling has few distinct keys (see
    :func:`arnold_period`).

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on
       multi-resolution representation and fuzzy logic", section 2 and section 3 step 5.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.message.scramble import arnold_scramble
    >>> image = np.arange(9).reshape(3, 3)
    >>> arnold_scramble(image, iterations=1).tolist()
    [[0, 7, 5], [8, 3, 1], [4, 2, 6]]
    """
    return _permute(image, _FORWARD, iterations)


def arnold_unscramble(image: NDArray, *, iterations: int) -> NDArray:
    """Undo :func:`arnold_scramble` with the same ``iterations``: exact inverse.

    Parameters
    ----------
    image : (N, N) array_like
        A scrambled image (any dtype).  Not modified.
    iterations : int
        The number of iterations it was scrambled with, >= 0.

    Returns
    -------
    (N, N) ndarray
        A new array of the same dtype with
        ``arnold_unscramble(arnold_scramble(x, iterations=k), iterations=k) == x``.

    Raises
    ------
    ValueError
        ``image`` is not a non-empty square 2-D array, or ``iterations`` is negative.
    TypeError
        ``iterations`` is not an integer.

    Notes
    -----
    Applies the inverse map ``P = (2P' - Q') mod N``, ``Q = (-P' + Q') mod N`` (matrix
    ``[[2, -1], [-1, 1]]``, the inverse of the forward matrix since its determinant is 1)
    ``iterations`` times, as one matrix power; it does not iterate on to the period.  Used at
    extraction (section 4, step 3 of the paper).

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.message.scramble import arnold_scramble, arnold_unscramble
    >>> image = np.arange(16).reshape(4, 4)
    >>> scrambled = arnold_scramble(image, iterations=5)
    >>> bool(np.array_equal(arnold_unscramble(scrambled, iterations=5), image))
    True
    """
    return _permute(image, _INVERSE, iterations)
