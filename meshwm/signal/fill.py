"""Image repair before decoding: fill samples a received mesh lost, find impulse spikes."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

__all__ = ["SPIKE_THRESHOLD", "fill_missing", "find_spikes"]


def fill_missing(gim: NDArray) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Fill NaN samples (parts of the grid the received mesh lost) smoothly from the rest.

    Nearest present sample first, then 64 Jacobi sweeps of the 4-neighbour average over the
    missing samples only, so the filled patch joins the rest without a step (a step would put
    energy into every detail coefficient near the cut).

    Returns
    -------
    filled : (N, N, 3) float64 ndarray
    missing : (N, N) bool ndarray
    """
    gim = np.asarray(gim, dtype=np.float64)
    missing = ~np.all(np.isfinite(gim), axis=-1)
    if not missing.any():
        return gim, missing
    if missing.all():
        raise ValueError("the geometry image has no samples")
    _, (ii, jj) = ndimage.distance_transform_edt(missing, return_indices=True)
    filled = gim[ii, jj]
    # The sweeps touch the missing samples only: their four neighbours (clamped at the
    # border, as an edge-padded image), summed in the same order as a whole-image sweep.
    n0, n1 = missing.shape
    mi, mj = np.nonzero(missing)
    up = np.maximum(mi - 1, 0) * n1 + mj
    down = np.minimum(mi + 1, n0 - 1) * n1 + mj
    left = mi * n1 + np.maximum(mj - 1, 0)
    right = mi * n1 + np.minimum(mj + 1, n1 - 1)
    at = mi * n1 + mj
    flat = filled.reshape(-1, filled.shape[-1])
    for _ in range(64):
        flat[at] = 0.25 * (flat[up] + flat[down] + flat[left] + flat[right])
    return filled, missing


#: A sample is a spike when it lies this many median sample spacings from its 3×3 median.
SPIKE_THRESHOLD = 4.0


def find_spikes(gim: NDArray) -> NDArray[np.bool_]:
    """Samples far from the median of their 3×3 neighbourhood: impulse noise to drop.

    On a sampled surface a sample lies within about one sample spacing of the median of its
    3×3 neighbourhood; a spike is :data:`SPIKE_THRESHOLD` median spacings away.  The paper's
    salt & pepper attack throws samples to the bounding box; dropping them
    (:func:`fill_missing` then refills them from their neighbours) turns a corrupted
    coefficient into a slightly noisy one.  NaN samples are not spikes.

    Examples
    --------
    >>> i, j = np.meshgrid(np.arange(32.0), np.arange(32.0), indexing="ij")
    >>> gim = np.stack([i, j, np.sin(i / 5) + np.cos(j / 7)], axis=-1)
    >>> gim[10, 20, 2] = 40.0
    >>> np.argwhere(find_spikes(gim)).tolist()
    [[10, 20]]
    """
    filled, missing = fill_missing(gim)
    med = ndimage.median_filter(filled, size=(3, 3, 1), mode="nearest")
    resid = np.linalg.norm(filled - med, axis=-1)
    step = np.linalg.norm(np.diff(filled, axis=0), axis=-1)
    spacing = float(np.median(step))
    if spacing <= 0:
        return np.zeros(missing.shape, dtype=bool)
    return (resid > SPIKE_THRESHOLD * spacing) & ~missing
