"""Embedding with the robust profile: distortion-compensated dither modulation of the slots."""

from __future__ import annotations

import numpy as np
import pywt
from numpy.typing import NDArray

from meshwm.metrics import psnr
from meshwm.profiles.robust.options import RobustOptions
from meshwm.profiles.robust.slots import (
    _CALIBRATION_START,
    WAVELET,
    RobustResult,
    _check,
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
    layout = _layout(gim.shape[0], key, len(bits))
    cover = _wavedec(gim)  # each embedding's first round starts from it
    normals = _Normals(gim)
    approx, _ = _split(cover)
    frames, scale = local_frames(approx)
    live = scale[layout.row, layout.col] > 0
    if options.tangential_step is not None:
        step = options.tangential_step
        marked = _embed_at(gim, bits, layout, frames, scale, _steps(approx, layout, step), cover)
    else:
        # Dithered quantisation moves each coefficient by a uniform fraction of its step, so
        # the distortion is proportional to the step: two corrections reach the target.
        step = _CALIBRATION_START
        for _ in range(3):
            marked = _embed_at(
                gim, bits, layout, frames, scale, _steps(approx, layout, step), cover
            )
            measured = normals.distortion(marked)
            if measured <= 0:
                break
            step = min(step * options.distortion / measured, 1.0)
        marked = _embed_at(gim, bits, layout, frames, scale, _steps(approx, layout, step), cover)
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
    (``cover``: ``_wavedec(gim)``, the first round's decomposition; read only)."""
    n = gim.shape[0]
    live = scale[layout.row, layout.col] > 0
    target = bits[layout.bit] / 2.0
    border = np.zeros((n, n), dtype=bool)
    border[[0, -1], :] = True
    border[:, [0, -1]] = True
    marked = gim.copy()
    want = None
    for round_ in range(_ROUNDS):
        coeffs = cover if round_ == 0 else _wavedec(marked)
        _, details = _split(coeffs)
        vals = _values(details, frames, scale, layout)
        if want is None:
            # Distortion compensation: move a fraction ALPHA of the way to the lattice point.
            t = vals / step - layout.dither
            want = vals + ALPHA * (np.floor(t - target + 0.5) + target - t) * step
        change = np.where(live, want - vals, 0.0)
        local = np.zeros((3, *scale.shape, 3))
        local[layout.band, layout.row, layout.col, layout.comp] = change * _unit(scale, layout)
        world = np.einsum("ijab,kija->kijb", frames, local)
        # The change of the level-3 details alone, all three channels in one call (the finer
        # levels' details are None: zero, bit for bit, without reconstructing them).
        delta = pywt.waverec2(
            [np.zeros_like(coeffs[0]), tuple(world), *[(None, None, None)] * (len(coeffs) - 2)],
            WAVELET,
            mode="periodization",
            axes=(0, 1),
        )
        delta[border] = 0.0
        marked += delta
    return marked


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
        self.diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
        self.total = float(self.area.sum())
        self.gim = gim

    def distortion(self, marked: NDArray) -> float:
        along = np.einsum("ijk,ijk->ij", self.unit, np.asarray(marked, dtype=np.float64) - self.gim)
        if self.diag <= 0 or self.total <= 0:
            return 0.0
        return float(np.sqrt(np.sum(self.area * along**2) / self.total)) / self.diag
