"""The paper's scheme made exact: its section 3 (steps 1-10) and section 4 on a geometry image.

On the geometry image (:func:`embed_gim_paper`, :func:`extract_gim_paper`):

1. **MRR** (steps 1-3): the paper's 3-level Haar packet tree of each of x, y and z
   (:func:`meshwm.signal.wavelet.mrr_decompose`).  Bits go into the 16 level-3 matrices, which all
   descend from the level-1 details CH and CV; the level-1 approximation CA is never changed.
2. **Canonical frame** (our addition; the paper asserts rotation invariance, but per-axis
   coefficients change under rotation).  From CA alone: the origin is the centroid of CA, the
   scale its RMS radius, and the axes come from the grid moments ``u = sum (i - c) CA[i, j]``
   and ``v = sum (j - c) CA[i, j]`` (Gram-Schmidt, then ``u × v``).  They rotate with the model
   and have no sign ambiguity, unlike principal axes.  Coefficients are read as 3-D vectors
   and expressed in this frame, so translation, rotation and uniform scale change nothing.
   The channels "x", "y", "z" of :class:`~meshwm.profiles.paper.options.PaperOptions` are the
   frame's axes.
3. **Perceptual mask** (steps 6-7): the fuzzy weight of each level-3 position from CA
   (:func:`meshwm.signal.mask.perceptual_weight`); HIGH and HIGHER positions carry bits.  Computed
   from CA, which embedding leaves alone, extraction sees the same mask; this is what makes
   extraction exact where the paper's model 3 reads back at 0.93 with no attack.
4. **Slots and key** (our addition; Arnold alone has 24 distinct scramblings at 32×32).  A slot
   is (channel, band, position) with the position off the outermost ring of blocks (those
   hold the welded seam samples, which must not move, see below).  An HMAC-SHA256 permutation
   of the slots, derived from the key, deals them out to the bits in turn, so every bit owns
   the same number of slots, spread over the whole model.  A slot carries its bit only where
   the mask says HIGH or HIGHER; a bit with fewer than ``min_carriers`` such slots also uses
   its others of the best fuzzy class, in the keyed order.  The assignment depends on
   positions, not on the set the mask selects, so a mask that differs by one coefficient at
   extraction (rounding at a class boundary) costs one vote of one bit, not a shifted stream.
5. **Remainder rule** (step 8): with step ``Δ = step × scale`` and a keyed dither ``u`` per
   slot, the coefficient ``c`` becomes the nearest value whose remainder ``(c/Δ - u) mod 1``
   equals ``remainder_one`` (bit 1) or ``remainder_zero`` (bit 0): the paper's "remainder
   greater than i / less than j" with the smallest change, made exact.  Targets half a step
   apart give the largest margin; the dither makes an unmarked coefficient's remainder a fair
   coin, so a wrong key reads noise.
6. **Inverse transform** (step 9) of the *changes* only, added to the geometry image: samples
   of untouched blocks, including every welded seam sample, keep their exact bits, so
   watertight stays watertight and the seams stay welded.
7. **Extraction** (section 4): the same frame, mask, slots and dither; each carrier votes
   ``cos 2π(r - j) - cos 2π(r - i)`` for its remainder ``r``, and a bit is the sign of its
   votes summed over carriers and channels (a soft vote).

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", sections 3 and 4.
.. [2] B. Chen, G. W. Wornell, "Quantization index modulation", IEEE Trans. Inf. Theory 47(4),
   2001, doi:10.1109/18.923725 (the dithered remainder rule).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import CapacityError, MeshError
from meshwm.message.keying import keyed_permutation, keyed_uniform
from meshwm.metrics import psnr
from meshwm.profiles.base import Decoded, Embedding
from meshwm.profiles.paper.options import CHANNELS, PaperOptions
from meshwm.signal.fuzzy import EMBEDDING_CLASSES, strength_class
from meshwm.signal.mask import perceptual_weight
from meshwm.signal.wavelet import mrr_decompose, mrr_reconstruct

__all__ = ["Frame", "canonical_frame", "embed_gim_paper", "extract_gim_paper"]

#: Level-3 coefficients cover 8×8 samples, 4×4 samples of CA.
_LEVEL3_BLOCK = 8


class Frame(NamedTuple):
    """A pose-free frame computed from CA: ``canonical = (world - origin) @ axes / scale``."""

    origin: NDArray[np.float64]
    axes: NDArray[np.float64]
    scale: float
    conditioning: float


def canonical_frame(ca: NDArray) -> Frame:
    """The pose-free frame of a geometry image, from its level-1 approximation CA.

    Parameters
    ----------
    ca : (M, M, 3) float64 ndarray
        CA of x, y and z stacked.

    Returns
    -------
    Frame
        ``conditioning`` is the smaller of ``|u| / (M² scale)`` and the sine of the angle
        between u and v; the frame is exact for any value above rounding, and a value under
        1e-6 is refused.

    Examples
    --------
    >>> m = 8
    >>> i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    >>> ca = np.stack([i, j, (i * j) % 3], axis=-1).astype(float)
    >>> f = canonical_frame(ca)
    >>> bool(np.allclose(f.axes.T @ f.axes, np.eye(3)))
    True
    """
    ca = np.asarray(ca, dtype=np.float64)
    m = ca.shape[0]
    pts = ca.reshape(-1, 3)
    origin = pts.mean(axis=0)
    centred = ca - origin
    scale = float(np.sqrt(np.mean(np.sum(centred**2, axis=-1))))
    if not np.isfinite(scale) or scale <= 0:
        raise MeshError("the geometry image is a single point; nothing to mark")
    ramp = np.arange(m, dtype=np.float64) - (m - 1) / 2
    u = np.einsum("i,ijk->k", ramp, centred)
    v = np.einsum("j,ijk->k", ramp, centred)
    nu, nv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    conditioning = 0.0
    if nu > 0 and nv > 0:
        e1 = u / nu
        w = v - (v @ e1) * e1
        conditioning = min(nu / (m * m * scale), float(np.linalg.norm(w)) / nv)
    if not np.isfinite(conditioning) or conditioning < 1e-6:
        raise MeshError(
            "the geometry image has no stable orientation (its grid moments vanish); "
            "it cannot be marked pose-independently"
        )
    e2 = w / np.linalg.norm(w)
    e3 = np.cross(e1, e2)
    return Frame(origin, np.stack([e1, e2, e3], axis=1), scale, conditioning)


class _Layout(NamedTuple):
    """The slots of one geometry-image size and parameter set, and their assignment to bits."""

    channel: NDArray[np.int64]  # index into options.channels
    band: NDArray[np.int64]  # index into options.bands
    row: NDArray[np.int64]
    col: NDArray[np.int64]
    bit: NDArray[np.int64]  # -1: the slot carries nothing
    rank: NDArray[np.int64]  # position of the slot in the keyed dealing order
    dither: NDArray[np.float64]


def _layout(n: int, options: PaperOptions, key: str | bytes, n_bits: int) -> _Layout:
    m = n // _LEVEL3_BLOCK
    inner = np.arange(1, m - 1)
    nc, nb, _ni = len(options.channels), len(options.bands), len(inner)
    c, b, r, q = np.meshgrid(np.arange(nc), np.arange(nb), inner, inner, indexing="ij")
    c, b, r, q = (x.ravel() for x in (c, b, r, q))
    total = len(c)
    per_bit = total // n_bits if n_bits else 0
    if per_bit < 1:
        raise CapacityError(
            f"{n_bits} bits do not fit: a size-{n} geometry image has {total} slots "
            f"with these channels and bands"
        )
    tag = f"meshwm/v1/n{n}/c{''.join(options.channels)}/b{'.'.join(options.bands)}"
    order = keyed_permutation(key, tag + "/slots", total)
    bit = np.full(total, -1, dtype=np.int64)
    dealt = order[: per_bit * n_bits]
    bit[dealt] = np.arange(len(dealt)) % n_bits
    rank = np.empty(total, dtype=np.int64)
    rank[order] = np.arange(total)
    dither = keyed_uniform(key, tag + "/dither", total)
    return _Layout(c, b, r, q, bit, rank, dither)


def _carriers(
    layout: _Layout, weight: NDArray[np.float64], n_bits: int, min_carriers: int
) -> NDArray[np.bool_]:
    """Which slots carry their bit: HIGH/HIGHER, topped up to ``min_carriers`` per bit.

    Top-up slots are taken by fuzzy *class* (higher first), then in the keyed dealing order.
    Not by the weight itself: weights that tie in exact arithmetic (a plane) differ in their
    last bits, and the rounding changes that embedding makes to CA would reorder them.
    """
    cls = strength_class(weight[layout.row, layout.col])
    use = np.isin(cls, EMBEDDING_CLASSES) & (layout.bit >= 0)
    count = np.bincount(layout.bit[use], minlength=n_bits)
    short = np.flatnonzero(count < min_carriers)
    if len(short):
        slot = np.flatnonzero(np.isin(layout.bit, short) & ~use)
        # Per bit: best class first, then the dealing order (np.lexsort: last key first).
        slot = slot[np.lexsort((layout.rank[slot], -cls[slot], layout.bit[slot]))]
        bit = layout.bit[slot]
        rank = np.arange(len(slot)) - np.searchsorted(bit, bit)
        need = (min_carriers - count)[bit]
        use[slot[rank < need]] = True
    return use


class _Slots(NamedTuple):
    """What embedding and extraction both derive from a geometry image, a key and a length."""

    coeffs: list[dict[str, NDArray[np.float64]]]  # MRR of x, y, z
    frame: Frame
    weight: NDArray[np.float64]  # fuzzy weight per level-3 position
    canon: NDArray[np.float64]  # level-3 coefficient vectors in the frame, (bands, m, m, 3)
    layout: _Layout
    use: NDArray[np.bool_]  # the slots that carry their bit
    channel: NDArray[np.int64]  # the frame axis of each slot
    values: NDArray[np.float64]  # each slot's coefficient in the frame, over the scale


def _slots(
    gim: NDArray[np.float64], options: PaperOptions, key: str | bytes, n_bits: int
) -> _Slots:
    coeffs = [mrr_decompose(gim[..., k]) for k in range(3)]
    ca = np.stack([coeffs[k]["a"] for k in range(3)], axis=-1)
    frame = canonical_frame(ca)
    weight = perceptual_weight(ca, block=_LEVEL3_BLOCK // 2)
    world = np.stack([np.stack([coeffs[k][b] for k in range(3)], axis=-1) for b in options.bands])
    canon = world @ frame.axes / frame.scale
    layout = _layout(gim.shape[0], options, key, n_bits)
    use = _carriers(layout, weight, n_bits, options.min_carriers)
    channel = np.array([CHANNELS.index(c) for c in options.channels])[layout.channel]
    values = canon[layout.band, layout.row, layout.col, channel]
    return _Slots(coeffs, frame, weight, canon, layout, use, channel, values)


def _check_gim(gim: NDArray) -> NDArray[np.float64]:
    gim = np.asarray(gim, dtype=np.float64)
    n = gim.shape[0] if gim.ndim == 3 else 0
    if gim.shape != (n, n, 3) or n < 2 * _LEVEL3_BLOCK or n & (n - 1):
        raise ValueError(
            f"gim must have shape (N, N, 3) with N a power of two >= {2 * _LEVEL3_BLOCK}, "
            f"got {gim.shape}"
        )
    if not np.all(np.isfinite(gim)):
        raise ValueError("gim contains NaN or infinite values")
    return gim


def _check_bits(bits: NDArray) -> NDArray[np.uint8]:
    arr = np.asarray(bits)
    if arr.ndim != 1 or len(arr) == 0:
        raise ValueError(f"bits must be a non-empty 1-D array, got shape {arr.shape}")
    if not np.all((arr == 0) | (arr == 1)):
        raise ValueError("bits must hold only 0 and 1")
    return arr.astype(np.uint8)


def embed_gim_paper(
    gim: NDArray,
    bits: NDArray,
    *,
    key: str | bytes,
    options: PaperOptions | None = None,
) -> Embedding:
    """Embed bits into a geometry image (section 3, steps 1-3 and 6-9 of [1]_).

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The cover geometry image, N a power of two.
    bits : (k,) array of 0/1
        The payload (already scrambled, for a mark).
    key : str or bytes
        The secret key.
    options : PaperOptions, optional
        Defaults to ``PaperOptions()``.

    Returns
    -------
    Embedding
        ``marked`` is the marked geometry image; the report has ``carriers`` (slots that
        carry a bit), ``carriers_per_bit_min``, ``capacity_bits`` (the payload at which an
        average bit still has ``min_carriers`` HIGH/HIGHER carriers; a longer payload is
        embedded, on fewer carriers per bit, so less robustly), ``used_bits``, ``psnr`` and
        ``frame_conditioning``.

    Examples
    --------
    >>> n = 64
    >>> i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    >>> gim = np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)
    >>> bits = np.arange(16) % 2
    >>> marked = embed_gim_paper(gim, bits, key="k").marked
    >>> extract_gim_paper(marked, 16, key="k").bits.tolist() == bits.tolist()
    True
    """
    options = options or PaperOptions()
    gim = _check_gim(gim)
    bits = _check_bits(bits)
    coeffs, frame, weight, canon, layout, use, ch, c = _slots(gim, options, key, len(bits))
    t = c / options.step - layout.dither
    target = np.where(
        bits[np.maximum(layout.bit, 0)] == 1, options.remainder_one, options.remainder_zero
    )
    t_new = np.floor(t - target + 0.5) + target
    delta_canon = np.zeros_like(canon)
    delta_canon[layout.band[use], layout.row[use], layout.col[use], ch[use]] = (t_new - t)[
        use
    ] * options.step
    # Back to world coordinates; only the changes are transformed, so untouched coefficients
    # and samples keep their exact values.
    delta_world = delta_canon @ frame.axes.T * frame.scale
    marked = gim.copy()
    for k in range(3):
        zero = {name: np.zeros_like(arr) for name, arr in coeffs[k].items()}
        for bi, name in enumerate(options.bands):
            zero[name] = delta_world[bi, ..., k]
        marked[..., k] += mrr_reconstruct(zero)
    count = np.bincount(layout.bit[use], minlength=len(bits))
    report = {
        "carriers": int(use.sum()),
        "carriers_per_bit_min": int(count.min()),
        # The payload at which an average bit still has min_carriers HIGH/HIGHER carriers.
        "capacity_bits": int(
            np.isin(strength_class(weight[1:-1, 1:-1]), EMBEDDING_CLASSES).sum()
            * len(options.bands)
            * len(options.channels)
            // options.min_carriers
        ),
        "used_bits": len(bits),
        "psnr": psnr(gim, marked),
        "frame_conditioning": frame.conditioning,
    }
    return Embedding(gim, marked, report)


def extract_gim_paper(
    gim: NDArray,
    n_bits: int,
    *,
    key: str | bytes,
    options: PaperOptions | None = None,
) -> Decoded:
    """Read ``n_bits`` bits from a geometry image, blind (section 4 of [1]_).

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The received geometry image.
    n_bits : int
        Payload length (for a mark: its side squared).
    key : str or bytes
        The secret key.
    options : PaperOptions, optional
        As used for embedding.

    Returns
    -------
    Decoded
        The bits (as carried: still scrambled for a mark), their soft votes, and a report with
        ``n`` and ``carriers``.
    """
    options = options or PaperOptions()
    gim = _check_gim(gim)
    if isinstance(n_bits, bool) or not isinstance(n_bits, (int, np.integer)) or n_bits < 1:
        raise ValueError(f"n_bits must be a positive integer, got {n_bits!r}")
    slots = _slots(gim, options, key, int(n_bits))
    layout, use = slots.layout, slots.use
    r = np.mod(slots.values[use] / options.step - layout.dither[use], 1.0)
    vote = np.cos(2 * np.pi * (r - options.remainder_one)) - np.cos(
        2 * np.pi * (r - options.remainder_zero)
    )
    norm = 1.0 - np.cos(2 * np.pi * (options.remainder_one - options.remainder_zero))
    total = np.bincount(layout.bit[use], weights=vote / norm, minlength=int(n_bits))
    count = np.bincount(layout.bit[use], minlength=int(n_bits))
    confidence = total / np.maximum(count, 1)
    bits = (total > 0).astype(np.uint8)
    report = {"n": int(gim.shape[0]), "carriers": int(use.sum())}
    return Decoded(bits, confidence, report)
