"""What grid recovery returns: :class:`RecoveredGrid`."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["RecoveredGrid"]


class RecoveredGrid(NamedTuple):
    """A grid read from connectivity.

    Attributes
    ----------
    n : int
        The grid size N.
    index : (N, N) int64 ndarray
        Vertex index of each grid sample (welded samples share a vertex); -1 for samples that
        were not read (cropped away, in a piece too small to read, or a border sample at a
        cut, see :func:`~meshwm.gim.recover.recover_grid`).  A sample that is read is always
        the right one.
    gim : (N, N, 3) float64 ndarray
        The geometry image: ``vertices[index]``, NaN where ``index`` is -1.
    hypotheses : int
        Hypotheses tried, for a Bonferroni correction: seed windows x 8 orientations (4
        rotations, 4 mirror images) x candidate sizes N, summed over components and pieces
        (a full mesh: 8 seeds x 8 x 3 sizes = 192).  A full propagation is run only for the
        few that match the code.  The count does not depend on the vertex or face order (the
        seeds are spread by vertex positions; only exact ties of positions fall back to the
        order).
    coverage : float
        Fraction of the N * N samples that have a vertex (1.0 for a complete grid).
    components : int
        Connected components that were read (merged into ``index``).
    """

    n: int
    index: NDArray[np.int64]  # type: ignore[assignment]  # shadows tuple.index
    gim: NDArray[np.float64]
    hypotheses: int
    coverage: float
    components: int
