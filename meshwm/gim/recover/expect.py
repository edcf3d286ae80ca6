"""The image a freshly written grid mesh reads back as, without writing or reading it."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.gim.code import border_cell_faces
from meshwm.gim.recover.table import _perimeter
from meshwm.gim.recover.verify import _fill_fold_tips
from meshwm.gim.to_mesh import _weld_faces

__all__ = ["expected_reading"]


def expected_reading(gim: NDArray[np.float64], weld: NDArray[np.int64]) -> NDArray[np.float64]:
    """What :func:`~meshwm.gim.recover.recover_grid` reads from the mesh
    :func:`~meshwm.gim.to_mesh.geometry_image_to_mesh` makes of ``gim`` and ``weld``.

    A welded sample reads as its root's vertex; the tips of welded folds (samples whose
    triangles all collapsed or closed into fins) as a perimeter neighbour's
    (:func:`~meshwm.gim.recover.verify._fill_fold_tips`); every other sample as itself.  Only
    border samples are welded, so only the triangles of the border cells are looked at (about
    8N instead of 2N²), and none of the N-grid's tables the reader builds (the embedder makes
    this beside the reading, which builds them).

    A prediction: where a root's vertex is also the vertex of other border samples, the reader
    may place it otherwise (stanford_bunny at N = 64: 2 corner samples; every development
    mesh at N = 128 to 512 reads as predicted).  The embedder reads its output back anyway
    (:func:`meshwm.watermark.embed.embed`, beside the marking) and marks again with what it
    read where the two differ.

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The geometry image, N >= 16.
    weld : (N, N) int64 ndarray
        Its weld map (:func:`meshwm.gim.remesh.mesh_to_geometry_image`).

    Returns
    -------
    (N, N, 3) float64 ndarray
        The image ``recover_grid`` gives (its ``gim``), a new array.

    Examples
    --------
    >>> n = 16
    >>> i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    >>> gim = np.stack([i, j, np.sin(i + j)], axis=-1).astype(float)
    >>> weld = np.arange(n * n).reshape(n, n)
    >>> bool(np.array_equal(expected_reading(gim, weld), gim))
    True
    """
    n = gim.shape[0]
    root = np.asarray(weld, dtype=np.int64).reshape(-1)
    prev, nxt = _perimeter(n)
    present = prev < 0  # interior samples: never welded, always in the mesh
    present[_weld_faces(border_cell_faces(n), root).ravel()] = True
    index = np.where(present[root], root, -1)
    _fill_fold_tips(index, prev, nxt)
    return np.asarray(gim, dtype=np.float64).reshape(-1, 3)[index].reshape(gim.shape)
