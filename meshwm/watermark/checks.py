"""Checks of the arrays the embedder and the extractor share: a geometry image, a mark."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from meshwm.message.mark import _check_bits as check_mark_bits
from meshwm.message.mark import default_mark
from meshwm.params import WatermarkParams

__all__ = ["check_gim", "check_mark"]


def check_gim(gim: NDArray, params: WatermarkParams) -> NDArray[np.float64]:
    """``gim`` as a finite ``(params.size, params.size, 3)`` float64 array, else ValueError."""
    gim = np.asarray(gim, dtype=np.float64)
    if gim.ndim != 3 or gim.shape != (params.size, params.size, 3):
        raise ValueError(
            f"gim must have shape ({params.size}, {params.size}, 3) for size={params.size}, "
            f"got {gim.shape}"
        )
    if not np.all(np.isfinite(gim)):
        raise ValueError("gim contains NaN or infinite values")
    return gim


def check_mark(mark: NDArray | None) -> NDArray[np.uint8]:
    """A square 0/1 mark as uint8; None gives the bundled 32×32 logo; else ValueError."""
    if mark is None:
        return default_mark(32)
    arr = check_mark_bits(mark)  # 2-D, 0/1, sane size
    if arr.shape[0] != arr.shape[1] or arr.shape[0] < 2:
        raise ValueError(f"mark must be a square 2-D 0/1 image, got shape {arr.shape}")
    return arr
