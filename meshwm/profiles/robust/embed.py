"""Embedding with the robust profile: distortion-compensated dither modulation of the slots."""

from __future__ import annotations

import functools
from collections.abc import Callable

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

__all__ = [
    "ALPHA",
    "CALIBRATION_EARLY_FROM",
    "CALIBRATION_EMBEDDINGS",
    "CALIBRATION_TOLERANCE",
    "embed_gim_robust",
    "normal_distortion",
]

#: Distortion compensation: the fraction of the way to the lattice point a coefficient moves.
ALPHA = 0.7
_ROUNDS = 3


def embed_gim_robust(
    gim: NDArray,
    bits: NDArray,
    *,
    key: str | bytes,
    options: RobustOptions | None = None,
    only: NDArray | None = None,
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
    only : (k,) array of bool, optional
        Move the slots of these bits only (the others keep their values): a mark that reads
        back a few bits wrong through a lossy carrier is reinforced where it is weak.  With a
        given ``tangential_step`` the lattice is the same as the whole embedding's.

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
        return _embed_at(gim, bits, layout, frames, scale, steps, cover, only=only)

    if options.tangential_step is not None:
        step = options.tangential_step
        marked = embed_at(step)
    else:
        early = CALIBRATION_TOLERANCE if gim.shape[0] >= CALIBRATION_EARLY_FROM else 0.0
        step, marked = _calibrated(
            embed_at, normals.distortion, options.distortion, tolerance=early
        )
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


#: Most embeddings the calibration makes.
CALIBRATION_EMBEDDINGS = 4
#: From this N the first embedding within :data:`CALIBRATION_TOLERANCE` of the distortion
#: target ends the calibration.
CALIBRATION_EARLY_FROM = 512
CALIBRATION_TOLERANCE = 0.01


def _calibrated(
    embed_at: Callable[[float], NDArray[np.float64]],
    distortion: Callable[[NDArray[np.float64]], float],
    target: float,
    *,
    tolerance: float,
) -> tuple[float, NDArray[np.float64]]:
    """The step whose embedding's distortion is ``target``, and that embedding.

    Dithered quantisation moves each coefficient by a uniform fraction of its step, so the
    distortion is nearly proportional to the step: each embedding but the last corrects the
    step by the ratio of the target to what it measured, and the last one made is returned.
    The first within ``tolerance`` (relative) of the target ends it early.  On the ten
    development meshes, two keys each, at N = 1024 the first correction came within 1 % on
    19 of 20 (the largest 1.6 %): there two embeddings (0.08 s each) do what four did.  Below
    N = 512 the corrections swing by a few percent (the dither's draw: bunny at N = 128 went
    +11 %, -5 %, +7 %) and an embedding costs milliseconds: there the calibration makes all
    four, as it always did (the kept mode's marks are made at N = 128, and the exact step
    decides some of them: genus-8 plate's cut start tipped with a step 1 % away).
    """
    step = _CALIBRATION_START
    for done in range(1, CALIBRATION_EMBEDDINGS + 1):
        marked = embed_at(step)
        if done == CALIBRATION_EMBEDDINGS:
            break
        measured = distortion(marked)
        if measured <= 0 or abs(measured - target) <= tolerance * target:
            break
        step = min(step * target / measured, 1.0)
    return step, marked


def _embed_at(
    gim: NDArray[np.float64],
    bits: NDArray[np.uint8],
    layout: _Layout,
    frames: NDArray[np.float64],
    scale: NDArray[np.float64],
    step: NDArray[np.float64],
    cover: list,
    *,
    only: NDArray | None = None,
) -> NDArray[np.float64]:
    """Quantise every live slot to its bit's lattice, keeping the border samples fixed
    (``cover``: ``_wavedec(gim)``, the first round's decomposition; read only).

    Each round reads the level-3 details of the image the rounds before made and moves them
    to the wanted values; the border samples are then put back, which changes the details
    near the border, and the next round corrects that.

    Where the image is large (N >= 512, :data:`_BORDER_ONLY_FROM`), the rounds follow the
    border alone.  All of a round is linear: the marked image is ``gim`` plus the
    reconstruction of the sum of the rounds' detail changes, its border put back, and a round's
    change moves the details by itself less the transform of its reconstruction's border
    samples (:func:`_border_of_change`, :func:`_details_of_border`: the 2-D transforms are
    separable, so both are products with 1-D operators).  One reconstruction of the whole image
    per embedding instead of three, and no decomposition of it (igea at N = 1024: 4
    embeddings 1.78 -> 0.57 s with strips of the image along its border, 0.33 s by the 1-D
    operators).  The same image to rounding (a test keeps the whole-image transforms of each
    round); below N = 512 the rounds transform the image whole, as they always did (the same
    bytes).
    """
    n = gim.shape[0]
    live = scale[layout.row, layout.col] > 0
    if only is not None:
        live = live & np.asarray(only, bool)[layout.bit]
    target = bits[layout.bit] / 2.0
    border_only = n >= _BORDER_ONLY_FROM
    if border_only:
        _, details = _split(cover)
        total = np.zeros_like(details)
    else:
        border = np.zeros((n, n), dtype=bool)
        border[[0, -1], :] = True
        border[:, [0, -1]] = True
        marked = gim.copy()
    want = None
    for round_ in range(_ROUNDS):
        if not border_only:
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
        if border_only:
            total += world
            if round_ + 1 < _ROUNDS:
                details = details + world - _details_of_border(_border_of_change(world, n), n)
        else:
            delta = _reconstruct(world)
            delta[border] = 0.0
            marked += delta
    if not border_only:
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


#: The smallest N whose rounds follow the border alone (:func:`_embed_at`).
_BORDER_ONLY_FROM = 512


@functools.lru_cache(maxsize=4)
def _operators(n: int) -> NDArray[np.float64]:
    """The 1-D level-3 synthesis operators of a length-``n`` signal, ``(2, m, n)``: row ``a`` of
    ``[0]`` is the signal of a unit approximation coefficient ``a``, of ``[1]`` of a unit
    level-3 detail (pywt's own 1-D reconstruction).

    The 2-D level-3 transforms are separable: a band's image is the outer product of the 1-D
    syntheses along each axis (approximation or detail per axis).  Periodized sym4 is an
    orthonormal transform, so the same rows are the analysis: column ``x`` holds the level-3
    coefficients of a unit sample at ``x`` (pywt's decomposition of the identity gave these
    numbers to 1.1e-16, at 16 ms and an N × N identity at N = 1024, 0.16 s at 2048).
    Read-only (cached).
    """
    m = n >> LEVEL
    eye = np.eye(m)
    zeros = np.zeros((m, m))
    finer = [np.zeros((m, m << k)) for k in range(1, LEVEL)]
    synthesis = np.stack(
        [
            pywt.waverec([eye, zeros, *finer], WAVELET, mode="periodization", axis=-1),
            pywt.waverec([zeros, eye, *finer], WAVELET, mode="periodization", axis=-1),
        ]
    )
    synthesis.flags.writeable = False
    return synthesis


#: Each detail band's type along axes 0 and 1 (0: approximation, 1: detail), in pywt's band
#: order (``cH``, ``cV``, ``cD``: keys ``da``, ``ad``, ``dd``).
_BANDS = ((1, 0), (0, 1), (1, 1))


def _border_of_change(world: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """The border samples of the reconstruction of level-3 details ``world`` (3, m, m, 3):
    rows 0 and N-1 and columns 0 and N-1 as a (4, N, 3) array.

    By separability: a band's row ``x`` is the 1-D synthesis along axis 1 of its coefficients
    weighted by the axis-0 synthesis at ``x`` (a column likewise, the axes swapped).
    """
    synthesis = _operators(n)
    m = n >> LEVEL
    ends = [synthesis[t][:, [0, -1]] for t in (0, 1)]  # (m, 2): each signal at 0 and N-1
    out = np.zeros((4, n, 3))
    for band, (p, q) in enumerate(_BANDS):
        w = world[band]  # (a, b, channel)
        rows = (ends[p].T @ w.reshape(m, -1)).reshape(2, m, 3)  # weighted along axis 0
        out[0:2] += (rows.transpose(0, 2, 1) @ synthesis[q]).transpose(0, 2, 1)
        cols = w.transpose(0, 2, 1) @ ends[q]  # (a, channel, 2): weighted along axis 1
        out[2:4] += (cols.transpose(2, 1, 0) @ synthesis[p]).transpose(0, 2, 1)
    return out


def _details_of_border(border: NDArray[np.float64], n: int) -> NDArray[np.float64]:
    """The level-3 details (3, m, m, 3) of the image that is ``border`` (:func:`_border_of_change`'s
    layout) on its border samples and zero elsewhere (the corners the rows').

    By separability: a unit sample row at ``x`` holding ``r`` has in band (p, q) the outer
    product of the axis-0 analysis of the unit sample at ``x`` and the axis-1 analysis of ``r``.
    """
    analysis = _operators(n)  # orthonormal: the synthesis rows
    m = n >> LEVEL
    first, last = border[2].copy(), border[3].copy()
    first[[0, -1]] = last[[0, -1]] = 0.0  # the corners are the rows' (counted once)
    # Per type (approximation, detail): the rows' analysis along axis 1 and the columns'
    # along axis 0 (2, m, 3 each), and each coefficient's weight of samples 0 and N-1 (m, 2).
    along = [analysis[t] @ border[0:2] for t in (0, 1)]
    across = [analysis[t] @ np.stack([first, last]) for t in (0, 1)]
    ends = [analysis[t][:, [0, -1]] for t in (0, 1)]
    out = np.empty((3, m, m, 3))
    for band, (p, q) in enumerate(_BANDS):
        out[band] = (ends[p] @ along[q].reshape(2, -1)).reshape(m, m, 3)
        out[band] += (across[p].transpose(2, 1, 0) @ ends[q].T).transpose(1, 2, 0)
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
    calibration measures its embeddings against it)."""

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
