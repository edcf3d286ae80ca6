"""Embedding with the robust profile: distortion-compensated dither modulation of the slots."""

from __future__ import annotations

import numpy as np
import pywt
from numpy.typing import NDArray

from meshwm._concurrent import beside
from meshwm.metrics import bounding_box_diagonal, psnr
from meshwm.profiles.robust.options import RobustOptions
from meshwm.profiles.robust.slots import (
    _CALIBRATION_START,
    LEVEL,
    WAVELET,
    RobustResult,
    _check,
    _guard,
    _Layout,
    _layout,
    _split,
    _steps,
    _unit,
    _values,
    _wavedec,
    local_frames,
)

__all__ = ["ALPHA", "embed_gim_robust", "normal_distortion"]

#: Distortion compensation: the fraction of the way to the lattice point a coefficient moves.
ALPHA = 0.7
_ROUNDS = 3


def embed_gim_robust(
    gim: NDArray, bits: NDArray, *, key: str | bytes, options: RobustOptions | None = None
) -> RobustResult:
    """Embed bits into a geometry image with the robust profile (see the module notes).

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The cover, finite.
    bits : (k,) array of 0/1
        The payload (already scrambled).
    key : str or bytes
        The secret key.
    options : RobustOptions, optional
        ``tangential_step`` is the tangential step over the local spacing; ``None`` (the
        default) calibrates it so that :func:`normal_distortion` is ``options.distortion``.

    Returns
    -------
    RobustResult
        ``gim`` is the marked geometry image; border samples are bit-identical to the cover.

    Examples
    --------
    >>> n = 64
    >>> i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    >>> gim = np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)
    >>> bits = np.arange(16) % 2
    >>> from meshwm.profiles.robust.decode import extract_gim_robust
    >>> marked = embed_gim_robust(gim, bits, key="k").gim
    >>> extract_gim_robust(marked, 16, key="k").bits.tolist() == bits.tolist()
    True
    """
    options = options or RobustOptions()
    gim = _check(gim, len(bits))
    bits = np.asarray(bits).astype(np.uint8)
    if not np.all(np.isfinite(gim)):
        raise ValueError("gim contains NaN or infinite values")
    # The cover's normals (numpy only) in a second thread while the keyed layout (HMAC, which
    # holds the GIL) and the decomposition are made (N = 1024: 0.11 s of 0.35 s hidden).
    with beside(_Normals, gim) as made:
        layout = _layout(gim.shape[0], key, len(bits))
        cover = _wavedec(gim)  # each embedding's first round starts from it
        approx, _ = _split(cover)
        frames, scale = local_frames(approx)
        live = scale[layout.row, layout.col] > 0
        guard = _guard(approx, layout)  # the calibration's embeddings share it
    normals = made.result()

    def embed_at(step: float) -> NDArray[np.float64]:
        steps = _steps(approx, layout, step, guard=guard)
        return _embed_at(gim, bits, layout, frames, scale, steps, cover)

    if options.tangential_step is not None:
        step = options.tangential_step
        marked = embed_at(step)
    else:
        # Dithered quantisation moves each coefficient by a uniform fraction of its step, so
        # the distortion is proportional to the step: two corrections reach the target.
        step = _CALIBRATION_START
        for _ in range(3):
            marked = embed_at(step)
            measured = normals.distortion(marked)
            if measured <= 0:
                break
            step = min(step * options.distortion / measured, 1.0)
        marked = embed_at(step)
    report = {
        "profile": "robust",
        "step": step,
        "distortion": normals.distortion(marked),
        "carriers": int(live.sum()),
        "carriers_per_bit_min": int(np.bincount(layout.bit[live], minlength=len(bits)).min()),
        "capacity_bits": int(live.sum()) // 3,
        "used_bits": len(bits),
        "psnr": psnr(gim, marked),
    }
    return RobustResult(marked, None, None, report)


def _embed_at(
    gim: NDArray[np.float64],
    bits: NDArray[np.uint8],
    layout: _Layout,
    frames: NDArray[np.float64],
    scale: NDArray[np.float64],
    step: NDArray[np.float64],
    cover: list,
) -> NDArray[np.float64]:
    """Quantise every live slot to its bit's lattice, keeping the border samples fixed
    (``cover``: ``_wavedec(gim)``, the first round's decomposition; read only).

    Each round reads the level-3 details of the image the rounds before made and moves them
    to the wanted values; the border samples are then put back, which changes the details
    near the border, and the next round corrects that.

    Where the image is large (N >= 512), the rounds are followed in strips.  All of a round
    is linear: the marked image is ``gim`` plus the reconstruction of the sum of the rounds'
    detail changes, its border put back, and a round's change moves the details by itself
    less the transform of its reconstruction's border samples, which only the strips of the
    image along its border carry (:func:`_border_of_change`, :func:`_details_of_border`:
    2 × 8 coefficient rows each way).  One reconstruction of the whole image per embedding
    instead of three, and no decomposition of it (igea at N = 1024: 4 embeddings 1.78 →
    0.57 s).  The same image to rounding (a test keeps the whole-image transforms of each
    round); below N = 512 the strips are not smaller than the image, and the rounds transform
    it whole, as they always did.
    """
    n = gim.shape[0]
    live = scale[layout.row, layout.col] > 0
    target = bits[layout.bit] / 2.0
    strips = 4 * _strip(n) < n >> LEVEL
    if strips:
        _, details = _split(cover)
        total = np.zeros_like(details)
    else:
        border = np.zeros((n, n), dtype=bool)
        border[[0, -1], :] = True
        border[:, [0, -1]] = True
        marked = gim.copy()
    want = None
    for round_ in range(_ROUNDS):
        if not strips:
            _, details = _split(cover if round_ == 0 else _wavedec(marked))
        vals = _values(details, frames, scale, layout)
        if want is None:
            # Distortion compensation: move a fraction ALPHA of the way to the lattice point.
            t = vals / step - layout.dither
            want = vals + ALPHA * (np.floor(t - target + 0.5) + target - t) * step
        change = np.where(live, want - vals, 0.0)
        local = np.zeros((3, *scale.shape, 3))
        local[layout.band, layout.row, layout.col, layout.comp] = change * _unit(scale, layout)
        world = np.einsum("ijab,kija->kijb", frames, local)
        if strips:
            total += world
            if round_ + 1 < _ROUNDS:
                details = details + world - _details_of_border(_border_of_change(world, n), n)
        else:
            delta = _reconstruct(world)
            delta[border] = 0.0
            marked += delta
    if not strips:
        return marked
    marked = gim + _reconstruct(total)
    for edge in (np.s_[0, :], np.s_[-1, :], np.s_[:, 0], np.s_[:, -1]):
        marked[edge] = gim[edge]
    return marked


def _reconstruct(world: NDArray[np.float64]) -> NDArray[np.float64]:
    """The image whose only coefficients are the level-3 details ``world`` (3 bands, m, m, 3),
    all three channels in one call (the finer levels' details None: zero, bit for bit,
    without reconstructing them)."""
    return pywt.waverec2(
        [np.zeros_like(world[0]), tuple(world), *[(None, None, None)] * (LEVEL - 1)],
        WAVELET,
        mode="periodization",
        axes=(0, 1),
    )


#: Coefficient rows on each side of the border that the strips hold: the sym4 level-3
#: synthesis filter spans 50 samples (7 × 7 + 1), under 7 coefficient rows.
_STRIP = 8


def _strip(n: int) -> int:
    """Coefficient rows a strip holds on each side of the border (the whole image if small)."""
    return min(_STRIP, (n >> LEVEL) // 2)


def _border_of_change(world: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """The border samples of the reconstruction of level-3 details ``world`` (3, m, m, 3):
    rows 0 and N-1 and columns 0 and N-1 as a (4, N, 3) array, from two strips.

    Periodization is shift-equivariant by whole coefficients: rolled by ``h`` coefficient
    rows the border lies in the middle of the first ``2h`` rows, whose reconstruction there
    depends on them only.
    """
    h = _strip(n)
    out = np.empty((4, n, 3))
    for axis in (0, 1):
        part = np.roll(world, h, axis=1 + axis).take(np.arange(2 * h), axis=1 + axis)
        image = _reconstruct(part)
        middle = h << LEVEL
        out[2 * axis] = image.take(middle, axis=axis)  # row (column) 0
        out[2 * axis + 1] = image.take(middle - 1, axis=axis)  # row (column) N - 1
    return out


def _details_of_border(border: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """The level-3 details (3, m, m, 3) of the image that is ``border`` (:func:`_border_of_change`'s
    layout) on its border samples and zero elsewhere, from two strips."""
    h = _strip(n)
    m = n >> LEVEL
    out = np.zeros((3, m, m, 3))
    middle = h << LEVEL
    rows = (np.arange(2 * h) - h) % m
    for axis in (0, 1):
        shape = (2 * middle, n, 3) if axis == 0 else (n, 2 * middle, 3)
        strip = np.zeros(shape)
        first, last = border[2 * axis], border[2 * axis + 1]
        if axis == 1:  # the corners are the rows' (counted once)
            first, last = first.copy(), last.copy()
            first[[0, -1]] = last[[0, -1]] = 0.0
        index = [slice(None)] * 3
        index[axis] = middle  # type: ignore[call-overload]
        strip[tuple(index)] = first
        index[axis] = middle - 1  # type: ignore[call-overload]
        strip[tuple(index)] = last
        coeffs = pywt.wavedec2(strip, WAVELET, mode="periodization", level=LEVEL, axes=(0, 1))
        bands = np.stack(coeffs[1])
        if axis == 0:
            out[:, rows] += bands
        else:
            out[:, :, rows] += bands
    return out


def normal_distortion(gim: NDArray, marked: NDArray) -> float:
    """RMS of the displacement along the surface normal, area-weighted, over the bbox diagonal.

    A first-order stand-in for the one-sided RMS surface distance (MRMS) that needs no
    MeshLab run: a move along the surface leaves the surface where it was.

    Examples
    --------
    >>> i, j = np.meshgrid(np.arange(16.0), np.arange(16.0), indexing="ij")
    >>> flat = np.stack([i, j, 0 * i], axis=-1)
    >>> lifted = flat + [0.0, 0.0, 0.15]
    >>> slid = flat + [0.3, 0.0, 0.0]
    >>> diagonal = np.sqrt(2) * 15
    >>> float(round(normal_distortion(flat, lifted) * diagonal, 12)), normal_distortion(flat, slid)
    (0.15, 0.0)
    """
    gim = np.asarray(gim, dtype=np.float64)
    return _Normals(gim).distortion(marked)


class _Normals:
    """:func:`normal_distortion` against one cover, its normals and areas computed once (the
    calibration measures three embeddings against it)."""

    def __init__(self, gim: NDArray[np.float64]) -> None:
        du = np.gradient(gim, axis=0)
        dv = np.gradient(gim, axis=1)
        normal = np.cross(du, dv)
        self.area = np.linalg.norm(normal, axis=-1)
        self.unit = normal / np.where(self.area > 0, self.area, 1.0)[..., None]
        pts = gim.reshape(-1, 3)
        self.diag = bounding_box_diagonal(pts)
        self.total = float(self.area.sum())
        self.gim = gim

    def distortion(self, marked: NDArray) -> float:
        along = np.einsum("ijk,ijk->ij", self.unit, np.asarray(marked, dtype=np.float64) - self.gim)
        if self.diag <= 0 or self.total <= 0:
            return 0.0
        return float(np.sqrt(np.sum(self.area * along**2) / self.total)) / self.diag
