"""The radial carrier's slots, projections and reading (see :mod:`meshwm.profiles.radial`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pywt
from numpy.typing import NDArray

from meshwm.errors import CapacityError
from meshwm.message.keying import keyed_permutation, keyed_uniform

__all__ = [
    "RADIAL_LEVEL",
    "RADIAL_STEP",
    "RadialLayout",
    "radial_layout",
    "radial_projections",
    "radial_spread",
    "read_radial_bits",
]

RADIAL_WAVELET = "sym4"
RADIAL_LEVEL = 3
#: The quantisation step of a bit's projection, in units of the point set's RMS radius.
RADIAL_STEP = 2e-3


class RadialLayout(NamedTuple):
    """Which slots carry which bit, with what sign and dither (from the key).

    Attributes
    ----------
    n : int
        Image size N.
    slots : (k, m) int64 ndarray
        Row b: the indices (into :func:`band` order) of bit b's ``m`` slots.
    signs : (k, m) float64 ndarray
        ±1 per slot.
    dither : (k,) float64 ndarray
        In [0, 1), in steps.
    """

    n: int
    slots: NDArray[np.int64]
    signs: NDArray[np.float64]
    dither: NDArray[np.float64]


def _slot_count(n: int) -> int:
    return 3 * (n >> RADIAL_LEVEL) ** 2


def radial_layout(n: int, key: str | bytes, n_bits: int) -> RadialLayout:
    """The key's layout of ``n_bits`` bits on an N×N image.

    Raises
    ------
    CapacityError
        Fewer slots than bits.

    Examples
    --------
    >>> lay = radial_layout(64, "k", 16)
    >>> lay.slots.shape, sorted(set(lay.signs.ravel().tolist()))
    ((16, 12), [-1.0, 1.0])
    """
    count = _slot_count(n)
    per = count // int(n_bits)
    if per < 1:
        raise CapacityError(
            f"a {n}×{n} spherical image has {count} slots, fewer than {n_bits} bits"
        )
    slots = keyed_permutation(key, "radial/slots", count)[: per * n_bits].reshape(n_bits, per)
    signs = np.where(keyed_uniform(key, "radial/signs", per * n_bits) < 0.5, -1.0, 1.0)
    dither = keyed_uniform(key, "radial/dither", n_bits)
    return RadialLayout(int(n), slots.astype(np.int64), signs.reshape(n_bits, per), dither)


def band(images: NDArray[np.float64]) -> NDArray[np.float64]:
    """The level-3 details of one image ``(N, N)`` or a stack ``(..., N, N)``, flattened."""
    coeffs = pywt.wavedec2(images, RADIAL_WAVELET, mode="periodization", level=RADIAL_LEVEL)
    lead = np.shape(images)[:-2]
    return np.concatenate([c.reshape(*lead, -1) for c in coeffs[1]], axis=-1)


def band_adjoint(values: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """The image whose level-3 details are ``values`` (``(..., 3 (N/8)²)``) and all else 0.

    The transform is orthogonal, so this is the adjoint of :func:`band`.
    """
    values = np.asarray(values, dtype=np.float64)
    lead = values.shape[:-1]
    m = n >> RADIAL_LEVEL
    parts = values.reshape(*lead, 3, m, m)
    coeffs: list = [np.zeros((*lead, m, m))]
    coeffs.append(tuple(parts[..., b, :, :] for b in range(3)))
    for level in range(RADIAL_LEVEL - 1, 0, -1):
        side = n >> level
        coeffs.append(tuple(np.zeros((*lead, side, side)) for _ in range(3)))
    out: NDArray[np.float64] = pywt.waverec2(coeffs, RADIAL_WAVELET, mode="periodization")
    return out


def radial_projections(image: NDArray[np.float64], layout: RadialLayout) -> NDArray[np.float64]:
    """Each bit's projection: its slots' signed sum over the square root of their number."""
    c = band(np.asarray(image, dtype=np.float64))
    per = layout.slots.shape[1]
    proj: NDArray[np.float64] = (c[..., layout.slots] * layout.signs).sum(axis=-1) / np.sqrt(per)
    return proj


def radial_spread(values: NDArray[np.float64], layout: RadialLayout) -> NDArray[np.float64]:
    """The adjoint of :func:`radial_projections`: ``(..., k)`` values to ``(..., N, N)`` images."""
    values = np.asarray(values, dtype=np.float64)
    lead = values.shape[:-1]
    per = layout.slots.shape[1]
    slots = np.zeros((*lead, _slot_count(layout.n)))
    slots[..., layout.slots] = values[..., :, None] * layout.signs / np.sqrt(per)
    return band_adjoint(slots, layout.n)


def read_radial_bits(
    projections: NDArray[np.float64], layout: RadialLayout, *, step: float = RADIAL_STEP
) -> tuple[NDArray[np.uint8], NDArray[np.float64]]:
    """Bits and confidences (``-cos 2π(p / step - dither)``, positive for a 1) of projections.

    Examples
    --------
    >>> lay = radial_layout(64, "k", 4)
    >>> p = (np.array([0, 1, 1, 0]) / 2 + lay.dither + 7) * RADIAL_STEP
    >>> read_radial_bits(p, lay)[0].tolist()
    [0, 1, 1, 0]
    """
    phase = 2.0 * np.pi * (np.asarray(projections) / step - layout.dither)
    confidence = -np.cos(phase)
    return (confidence > 0).astype(np.uint8), confidence


def lattice_change(
    projections: NDArray[np.float64],
    bits: NDArray[np.uint8],
    layout: RadialLayout,
    *,
    step: float = RADIAL_STEP,
) -> NDArray[np.float64]:
    """The change that brings each projection to the nearest point of its bit's lattice."""
    t = np.asarray(projections) / step - layout.dither
    half = np.asarray(bits, dtype=np.float64) / 2.0
    return (np.floor(t - half + 0.5) + half - t) * step
