"""Coordinates in text formats (OBJ, OFF, ASCII PLY and STL): written as the file writes them.

A text file has no dtype; its precision is the number of digits its writer used.  A rewritten
coordinate keeps the file's style (fixed decimals, or exponent notation) and its number of
digits, with at least enough of them to resolve :data:`RESOLUTION` of the bounding-box
diagonal, so that the mark survives the rounding: the marks measured move the surface by
about 1e-4 of the diagonal, and 16-bit quantisation (1.5e-5) does not erase them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["RESOLUTION", "TextStyle", "infer_style"]

#: The coarsest rounding of a rewritten coordinate, as a fraction of the bounding-box diagonal.
RESOLUTION = 1e-6
#: Tokens looked at to infer a file's style.
_SAMPLE = 30_000
_MAX_DIGITS = 17


class TextStyle(NamedTuple):
    """How a file writes its coordinates: fixed ``digits`` decimals, or exponent notation."""

    exponent: bool
    digits: int

    def format(self, values: NDArray[np.float64]) -> list[str]:
        """Each value as text in this style.

        Examples
        --------
        >>> TextStyle(False, 3).format(np.array([0.12345, -2.0]))
        ['0.123', '-2.000']
        >>> TextStyle(True, 4).format(np.array([0.12345]))
        ['1.2345e-01']
        """
        spec = f".{self.digits}{'e' if self.exponent else 'f'}"
        return [format(x, spec) for x in np.asarray(values, dtype=np.float64).tolist()]


def _decimals(token: bytes) -> int:
    mantissa = token.lower().split(b"e", 1)[0]
    dot = mantissa.find(b".")
    return 0 if dot < 0 else len(mantissa) - dot - 1


def infer_style(tokens: Sequence[bytes], positions: NDArray[np.float64]) -> TextStyle:
    """The style of ``tokens`` (a file's coordinates), with digits enough for the mark.

    Parameters
    ----------
    tokens : sequence of bytes
        Coordinate tokens as the file writes them (a sample is looked at).
    positions : (N, 3) float64 ndarray
        The file's positions, for the bounding-box diagonal.

    Examples
    --------
    >>> p = np.array([[0.0, 0, 0], [1.0, 1, 1]])
    >>> infer_style([b"0.5", b"0.25000000"], p)
    TextStyle(exponent=False, digits=8)
    >>> infer_style([b"1", b"0.5"], p)  # too coarse for the mark: 1e-6 of the diagonal
    TextStyle(exponent=False, digits=6)
    >>> infer_style([b"1.000000e+00"], p)
    TextStyle(exponent=True, digits=6)
    """
    sample = list(tokens[:_SAMPLE])
    exponent = any(b"e" in t.lower() for t in sample)
    digits = max((_decimals(t) for t in sample), default=0)
    finite = positions[np.isfinite(positions).all(axis=1)] if len(positions) else positions
    if len(finite):
        diagonal = float(np.linalg.norm(finite.max(axis=0) - finite.min(axis=0)))
        largest = float(np.abs(finite).max())
    else:
        diagonal = largest = 0.0
    if diagonal > 0:
        need = RESOLUTION * diagonal
        if exponent:
            digits = max(digits, math.ceil(math.log10(max(largest, need)) - math.log10(need)))
        else:
            digits = max(digits, math.ceil(-math.log10(need)))
    return TextStyle(exponent, min(max(digits, 0), _MAX_DIGITS))
