"""The robust profile's slots: the sym4 level-3 transform, local frames, keyed layout, steps.

What embedding (:mod:`meshwm.profiles.robust.embed`) and decoding
(:mod:`meshwm.profiles.robust.decode`) both derive from a geometry image and a key; the method is
described in :mod:`meshwm.profiles.robust`.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np
import pywt
from numpy.typing import NDArray

from meshwm.errors import CapacityError
from meshwm.message.keying import keyed_permutation, keyed_uniform
from meshwm.signal.fuzzy import strength_class
from meshwm.signal.mask import perceptual_weight

__all__ = ["LEVEL", "NORMAL_RATIO", "WAVELET", "RobustResult", "local_frames"]

WAVELET = "sym4"
LEVEL = 3
#: Step of the normal component relative to the tangential ones.
NORMAL_RATIO = 0.25
#: Step multiplier where the fuzzy guard finds the surface smooth (classes 0..2).
GUARD_RATIO = 0.7
GUARD_CLASSES = (0, 1, 2)
#: First step of the per-mesh calibration (``tangential_step`` is None).
_CALIBRATION_START = 0.03


class RobustResult(NamedTuple):
    """Output of :func:`embed_gim_robust` / :func:`extract_gim_robust`."""

    gim: NDArray[np.float64] | None
    bits: NDArray[np.uint8] | None
    confidence: NDArray[np.float64] | None
    report: dict[str, Any]


def _wavedec(gim: NDArray[np.float64]) -> list:
    """The sym4 level-3 decomposition of x, y and z in one call (``axes=(0, 1)``: bit for bit
    the three channels' own decompositions, without three calls' overhead)."""
    return pywt.wavedec2(gim, WAVELET, mode="periodization", level=LEVEL, axes=(0, 1))


def _split(coeffs: list) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(approximation (m, m, 3), level-3 details (3 bands, m, m, 3)) of :func:`_wavedec`'s."""
    return coeffs[0], np.stack(coeffs[1])


def local_frames(approx: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """An orthonormal frame and a length scale at every position of a coarse approximation.

    Parameters
    ----------
    approx : (m, m, 3) float64 ndarray
        The level-3 approximation of x, y and z.

    Returns
    -------
    frames : (m, m, 3, 3) float64 ndarray
        Rows: unit tangent along the first grid axis, the binormal, the unit normal.
    scale : (m, m) float64 ndarray
        Geometric mean of the two tangent lengths: the local spacing of the approximation.
        0 where the surface is degenerate (the frame there is garbage and ``scale`` says so).

    Examples
    --------
    >>> i, j = np.meshgrid(np.arange(8.0), np.arange(8.0), indexing="ij")
    >>> f, s = local_frames(np.stack([2 * i, 2 * j, 0 * i], axis=-1))
    >>> f[3, 3].round(6).tolist(), float(s[3, 3])
    ([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], 2.0)
    """
    tu = np.gradient(approx, axis=0)
    tv = np.gradient(approx, axis=1)
    lu = np.linalg.norm(tu, axis=-1)
    lv = np.linalg.norm(tv, axis=-1)
    normal = np.cross(tu, tv)
    ln = np.linalg.norm(normal, axis=-1)
    # Relative floors: a tangent shorter than a millionth of the typical one is rounding.
    ref = float(np.median(np.maximum(lu, lv)))
    ok = (lu > 1e-6 * ref) & (lv > 1e-6 * ref) & (ln > 1e-6 * lu * lv) & (ref > 0)
    e1 = tu / np.where(ok, lu, 1.0)[..., None]
    e3 = normal / np.where(ok, ln, 1.0)[..., None]
    e2 = np.cross(e3, e1)
    frames = np.stack([e1, e2, e3], axis=-2)
    scale = np.where(ok, np.sqrt(lu * lv), 0.0)
    return frames, scale


class _Layout(NamedTuple):
    band: NDArray[np.int64]
    comp: NDArray[np.int64]
    row: NDArray[np.int64]
    col: NDArray[np.int64]
    bit: NDArray[np.int64]
    dither: NDArray[np.float64]
    by_bit: NDArray[np.int64]  # slots sorted by bit (stable), for np.add.reduceat
    starts: NDArray[np.int64]  # where each bit's slots start in ``by_bit``


def _layout(n: int, key: str | bytes, n_bits: int) -> _Layout:
    """The keyed slot layout (cached: a batch reads many files with one key; read-only)."""
    return _cached_layout(int(n), bytes(key) if isinstance(key, bytearray) else key, int(n_bits))


@functools.lru_cache(maxsize=8)
def _cached_layout(n: int, key: str | bytes, n_bits: int) -> _Layout:
    layout = _make_layout(n, key, n_bits)
    for a in layout:
        a.flags.writeable = False
    return layout


class _Slots(NamedTuple):
    """The slots in their fixed (unkeyed) order: band, component, level-3 row and column."""

    band: NDArray[np.int64]
    comp: NDArray[np.int64]
    row: NDArray[np.int64]
    col: NDArray[np.int64]


@functools.lru_cache(maxsize=8)
def _slots(n: int) -> _Slots:
    m = n >> LEVEL
    inner = np.arange(1, m - 1)  # the outer ring wraps around (periodization) and holds seams
    grids = np.meshgrid(np.arange(3), np.arange(3), inner, inner, indexing="ij")
    slots = _Slots(*(x.ravel() for x in grids))
    for a in slots:
        a.flags.writeable = False
    return slots


def _make_layout(n: int, key: str | bytes, n_bits: int) -> _Layout:
    b, c, r, q = _slots(n)
    total = len(b)
    if n_bits > total:
        raise CapacityError(
            f"{n_bits} bits do not fit: a size-{n} geometry image has {total} robust slots"
        )
    tag = f"meshwm/robust/v1/n{n}"
    order = keyed_permutation(key, tag + "/slots", total)
    bit = np.empty(total, dtype=np.int64)
    bit[order] = np.arange(total) % n_bits
    dither = keyed_uniform(key, tag + "/dither", total)
    by_bit = np.argsort(bit, kind="stable")
    starts = np.searchsorted(bit[by_bit], np.arange(n_bits))
    return _Layout(b, c, r, q, bit, dither, by_bit, starts)


def _guard(approx: NDArray, layout: _Slots | _Layout) -> NDArray[np.float64]:
    """Per-slot step multiplier of the fuzzy guard: :data:`GUARD_RATIO` where it finds the
    surface smooth, else 1 (it depends on the approximation only, not on the step)."""
    weight = perceptual_weight(approx, block=1)
    guard = np.where(np.isin(strength_class(weight), GUARD_CLASSES), GUARD_RATIO, 1.0)
    return guard[layout.row, layout.col]


def _steps(
    approx: NDArray,
    layout: _Slots | _Layout,
    step: float,
    *,
    guard: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Per-slot step over the local scale: tangential ``step``, normal a quarter; guarded
    (``guard``: :func:`_guard` of ``approx``, if found already)."""
    if guard is None:
        guard = _guard(approx, layout)
    per = np.where(layout.comp == 2, NORMAL_RATIO, 1.0) * step
    return per * guard


def _unit(scale: NDArray[np.float64], layout: _Slots | _Layout) -> NDArray[np.float64]:
    """Per-slot length unit: the median spacing of the approximation (0 where degenerate)."""
    s = scale[layout.row, layout.col]
    live = scale > 0
    ref = float(np.median(scale[live])) if live.any() else 0.0
    return np.where(s > 0, ref, 0.0)


def _values(details: NDArray, frames: NDArray, scale: NDArray, layout: _Slots | _Layout) -> NDArray:
    """Slot values: detail vectors in the local frame, over the length unit (0 if degenerate)."""
    local = np.einsum("ijab,kijb->kija", frames, details)
    s = _unit(scale, layout)
    v = local[layout.band, layout.row, layout.col, layout.comp]
    return np.where(s > 0, v / np.where(s > 0, s, 1.0), 0.0)


def _check(gim: NDArray, n_bits: int) -> NDArray[np.float64]:
    gim = np.asarray(gim, dtype=np.float64)
    n = gim.shape[0] if gim.ndim == 3 else 0
    if gim.ndim != 3 or gim.shape != (n, n, 3) or n < 32 or n & (n - 1):
        raise ValueError(f"gim must be (N, N, 3) with N a power of two >= 32, got {gim.shape}")
    if isinstance(n_bits, bool) or not isinstance(n_bits, (int, np.integer)) or n_bits < 1:
        raise ValueError(f"n_bits must be a positive integer, got {n_bits!r}")
    return gim
