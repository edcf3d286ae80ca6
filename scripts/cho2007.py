"""Cho, Prost & Jung 2007, method I: the baseline of issue #13's comparison table.

A blind watermark in the distribution of vertex norms.  The vertices are taken in spherical
coordinates about the mesh's centre of gravity; the norms ρ are split into N bins of equal
width between ρ_min and ρ_max; inside bin n the norms are normalised to [0, 1] by the bin's
bounds.  One bit per bin: the mean of the normalised norms is pushed to at least 1/2 + α
(bit 1) or at most 1/2 − α (bit 0) by the histogram mapping ρ̃' = ρ̃^k, and each vertex
moves along its direction from the centre.  Extraction recomputes the centre, the bins and
the means: bit = mean > 1/2.

Choices where the paper leaves room (or where this port departs from it):

- ``k`` is found per bin by bisection on log k (60 halvings, all bins at once) instead of the
  paper's fixed steps Δk: the mean lands on 1/2 ± α, never short of it.  k = 1 (no change)
  when the bin's mean is already beyond the target.
- The centre of gravity is the mean of the vertices (the paper's); ``centre="surface"`` uses
  the area-weighted centroid of the faces instead (steadier under re-tessellation).
- Moving the vertices moves the centre and so every bin (the paper marks once).  Here the
  input is marked about a centre c found by fixed-point iteration, c = centre of (the input
  marked about c), up to ``passes`` (default 10) times; each pass marks the input afresh, so
  the distortion does not pile up, and the pass that leaves the fewest bins more than α/10
  short of their target about the marked mesh's own centre is kept.
- The key: bit j of the payload goes to bin ``perm[j]`` and is XOR-ed with a keyed flip, both
  from HMAC-SHA256 (:mod:`meshwm.message.keying`), so a wrong key reads about half the bits.
- A bin without vertices cannot carry its bit; it reads as mean 1/2 (bit 0 before the flip).

The payload is meshwm's: :func:`meshwm.message.payload.encode_id` (256 code bits, one bin per
bit) or the raw 64 id bits (64 bins).  :func:`cho_reads_id` is the harness's test.

    python scripts/cho2007.py MESH --target 0.0002 [--raw] [--attacks noise laplacian ...]

References
----------
J.-W. Cho, R. Prost, H.-Y. Jung, "An oblivious watermarking for 3-D polygonal meshes using
distribution of vertex norms", IEEE Trans. Signal Processing 55(1):142-155, 2007.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from meshwm.message.keying import keyed_permutation, keyed_uniform
from meshwm.message.payload import ID_BITS, PAYLOAD_BITS, decode_id, encode_id

__all__ = [
    "BinStats",
    "bin_statistics",
    "calibrate_cho",
    "cho_reads_id",
    "embed_cho",
    "extract_cho",
    "extract_cho_soft",
    "id_bits",
    "mrms_rel",
]

CENTRES = ("vertices", "surface")
_LOG_K = np.log(1e3)  # k is searched in [1e-3, 1e3]
_HALVINGS = 60
_PURPOSE = "cho2007"
_HAIR = 1e-9
#: A later pass re-marks only the bins more than this fraction of α short of their target.
_SLACK = 0.1


class BinStats(NamedTuple):
    """The bins of one mesh about its centre.

    Attributes
    ----------
    bin_of : (n,) int64
        Bin of each vertex.
    normalised : (n,) float64
        ρ̃ in [0, 1]: the norm relative to its bin's bounds.
    means : (n_bins,) float64
        Mean of ρ̃ per bin (1/2 for an empty bin).
    counts : (n_bins,) int64
        Vertices per bin.
    centre : (3,) float64
    norms : (n,) float64
        ρ, the distance of each vertex to the centre.
    """

    bin_of: NDArray[np.int64]
    normalised: NDArray[np.float64]
    means: NDArray[np.float64]
    counts: NDArray[np.int64]
    centre: NDArray[np.float64]
    norms: NDArray[np.float64]


def _check(vertices: NDArray, faces: NDArray, n_bins: int) -> tuple[NDArray, NDArray]:
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 2:
        raise ValueError(f"vertices must be (n, 3) with n >= 2, got shape {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must be (m, 3), got shape {f.shape}")
    if isinstance(n_bins, bool) or not isinstance(n_bins, (int, np.integer)) or n_bins < 1:
        raise ValueError(f"the number of bits (bins) must be a positive integer, got {n_bins!r}")
    return v, f


def _centre(v: NDArray, f: NDArray, centre: str) -> NDArray[np.float64]:
    if centre == "vertices":
        return v.mean(axis=0)
    if centre == "surface":
        tri = v[f]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        if area.sum() <= 0:
            raise ValueError("centre='surface' needs faces of positive area")
        return (area[:, None] * tri.mean(axis=1)).sum(axis=0) / area.sum()
    raise ValueError(f"unknown centre {centre!r}; valid: {', '.join(CENTRES)}")


def bin_statistics(
    vertices: NDArray, faces: NDArray, n_bins: int, *, centre: str = "vertices"
) -> BinStats:
    """Centre, norms, bins and per-bin means of normalised norms (the paper's eqs. 1-4).

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
        Used only for ``centre="surface"``.
    n_bins : int
        N, bins of equal width between the smallest and the largest norm.
    centre : {"vertices", "surface"}
        Mean of the vertices (the paper) or area-weighted centroid of the surface.
    """
    v, f = _check(vertices, faces, n_bins)
    return _bins_about(v, _centre(v, f, centre), n_bins)


def _bins_about(v: NDArray, c: NDArray, n_bins: int) -> BinStats:
    rho = np.linalg.norm(v - c, axis=1)
    lo, hi = float(rho.min()), float(rho.max())
    width = (hi - lo) / n_bins
    if width <= 0:
        raise ValueError("every vertex lies at the same distance from the centre")
    index = np.clip(np.floor((rho - lo) / width).astype(np.int64), 0, n_bins - 1)
    normalised = np.clip((rho - lo) / width - index, 0.0, 1.0)
    counts = np.bincount(index, minlength=n_bins)
    sums = np.bincount(index, weights=normalised, minlength=n_bins)
    means = np.where(counts > 0, sums / np.maximum(counts, 1), 0.5)
    return BinStats(index, normalised, means, counts, c, rho)


def _layout(key: str | bytes, n_bins: int) -> tuple[NDArray[np.int64], NDArray[np.uint8]]:
    """Bin of each payload bit, and the keyed flip XOR-ed onto it."""
    perm = keyed_permutation(key, f"{_PURPOSE}/bins", n_bins)
    flip = (keyed_uniform(key, f"{_PURPOSE}/flip", n_bins) < 0.5).astype(np.uint8)
    return perm, flip


def _unmet(
    stats: BinStats, targets: NDArray[np.uint8], alpha: float, *, slack: float = 0.0
) -> NDArray[np.bool_]:
    """Bins with vertices whose mean is short of 1/2 + a (a 1) or 1/2 − a (a 0), a = α − slack."""
    one = targets.astype(bool)
    a = alpha - slack
    short = np.where(one, stats.means < 0.5 + a, stats.means > 0.5 - a)
    return short & (stats.counts > 0)


def _exponents(stats: BinStats, targets: NDArray[np.uint8], alpha: float) -> NDArray:
    """k per bin: mean(ρ̃^k) ≥ 1/2 + α for a 1, ≤ 1/2 − α for a 0 (bisection on log k).

    The bisection aims a hair (1e-9) beyond the target, so that rounding does not leave a bin
    just short of it.  k = 1 for a bin that already meets it.
    """
    n_bins = len(stats.means)
    one = targets.astype(bool)
    goal = np.where(one, 0.5 + alpha + _HAIR, 0.5 - alpha - _HAIR)
    todo = _unmet(stats, targets, alpha)
    lo = np.where(one & todo, -_LOG_K, 0.0)  # log k
    hi = np.where(~one & todo, _LOG_K, 0.0)
    x, idx = stats.normalised, stats.bin_of
    counts = np.maximum(stats.counts, 1)
    for _ in range(_HALVINGS):
        mid = 0.5 * (lo + hi)
        mean = np.bincount(idx, weights=x ** np.exp(mid)[idx], minlength=n_bins) / counts
        feasible = np.where(one, mean >= goal, mean <= goal)
        # mean(x^k) falls with k: a 1 keeps the largest feasible k, a 0 the smallest.
        lo = np.where(one == feasible, mid, lo)
        hi = np.where(one == feasible, hi, mid)
    return np.exp(np.where(one, lo, hi))


def embed_cho(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray,
    *,
    key: str | bytes,
    alpha: float,
    centre: str = "vertices",
    passes: int = 10,
) -> NDArray[np.float64]:
    """Mark ``bits`` in the vertex-norm distribution (method I), one bin per bit.

    Parameters
    ----------
    vertices : (n, 3) float64
    faces : (m, 3) int64
        Unchanged by the mark; used for ``centre="surface"``.
    bits : (n_bits,) array of 0/1
        The payload; N = n_bits bins.
    key : str or bytes
        Secret of the bin permutation and the bit flips.
    alpha : float
        Strength in (0, 1/2): the bin means are pushed to 1/2 ± alpha.
    centre : {"vertices", "surface"}
        See :func:`bin_statistics`.
    passes : int
        Embeddings about the re-computed centre (the mark moves it); stops early when every
        bin meets its target, and returns the pass with the fewest bins short of it.

    Returns
    -------
    (n, 3) float64 ndarray
        Marked vertices, same order; faces are unchanged.
    """
    b = np.asarray(bits)
    if b.ndim != 1 or not np.all((b == 0) | (b == 1)):
        raise ValueError(f"bits must be a 1-D array of 0/1, got shape {b.shape}")
    if not 0 < alpha < 0.5:
        raise ValueError(f"alpha must lie in (0, 0.5), got {alpha!r}")
    if isinstance(passes, bool) or not isinstance(passes, int) or passes < 1:
        raise ValueError(f"passes must be a positive integer, got {passes!r}")
    v, f = _check(vertices, faces, len(b))
    perm, flip = _layout(key, len(b))
    targets = np.zeros(len(b), dtype=np.uint8)
    targets[perm] = b.astype(np.uint8) ^ flip
    # The mark moves the centre, and with it every bin.  Find the centre c that the marked mesh
    # has when the input is marked about c: a fixed point, by iteration; every pass marks the
    # input (not the last pass's output), so the distortion does not pile up.
    c = _centre(v, f, centre)
    best: tuple[int, NDArray[np.float64]] = (len(b) + 1, v)
    for _ in range(passes):
        stats = _bins_about(v, c, len(b))
        k = _exponents(stats, targets, alpha)
        width = (stats.norms.max() - stats.norms.min()) / len(b)
        rho_new = stats.norms + width * (stats.normalised ** k[stats.bin_of] - stats.normalised)
        scale = np.divide(rho_new, stats.norms, out=np.ones_like(rho_new), where=stats.norms > 0)
        out = c + (v - c) * scale[:, None]
        c_new = _centre(out, f, centre)
        unmet = int(
            _unmet(_bins_about(out, c_new, len(b)), targets, alpha, slack=_SLACK * alpha).sum()
        )
        if unmet < best[0]:
            best = (unmet, out)
        if unmet == 0 or np.array_equal(c_new, c):
            break
        c = c_new
    # A vertex on a bin bound can make the iteration cycle: keep the pass that left the fewest
    # bins short of their target (by more than a tenth of α) about the marked mesh's own centre.
    out = best[1]
    return out


def extract_cho_soft(
    vertices: NDArray, faces: NDArray, n_bits: int, *, key: str | bytes, centre: str = "vertices"
) -> NDArray[np.float64]:
    """Blind soft read: (bin mean − 1/2) per payload bit, signed so that > 0 means a 1."""
    stats = bin_statistics(vertices, faces, n_bits, centre=centre)
    perm, flip = _layout(key, n_bits)
    soft = stats.means[perm] - 0.5
    return np.where(flip == 1, -soft, soft)


def extract_cho(
    vertices: NDArray, faces: NDArray, n_bits: int, *, key: str | bytes, centre: str = "vertices"
) -> NDArray[np.uint8]:
    """Blind read of ``n_bits`` bits (bit = bin mean > 1/2), in payload order.

    Returns
    -------
    (n_bits,) uint8 ndarray of 0/1
    """
    return (extract_cho_soft(vertices, faces, n_bits, key=key, centre=centre) > 0).astype(np.uint8)


def mrms_rel(vertices_a: NDArray, faces_a: NDArray, vertices_b: NDArray, faces_b: NDArray,
             *, samples: int = 200_000) -> float:  # fmt: skip
    """MRMS (larger one-sided RMS surface distance, MeshLab) over the diagonal of ``a``."""
    from meshwm.metrics import bounding_box_diagonal, surface_distance

    d = surface_distance(vertices_a, faces_a, vertices_b, faces_b, samples=samples)
    return d.rms / bounding_box_diagonal(vertices_a)


def calibrate_cho(
    vertices: NDArray,
    faces: NDArray,
    bits: NDArray,
    *,
    key: str | bytes,
    target_mrms_rel: float,
    tolerance: float = 0.03,
    max_evaluations: int = 10,
    centre: str = "vertices",
    samples: int = 200_000,
) -> tuple[NDArray[np.float64], float]:
    """Embed with the α whose MRMS against the input is ``target_mrms_rel``.

    MRMS is measured with MeshLab (:func:`mrms_rel`); α is found by a secant on log MRMS
    against log α, kept inside a bracket once one is known (geometric bisection when the secant
    leaves it).  Stops when the relative error is within ``tolerance`` or after
    ``max_evaluations``; returns the closest evaluation.

    Returns
    -------
    vertices : (n, 3) float64 ndarray
        Marked with the chosen α.
    alpha : float
    """
    if not target_mrms_rel > 0:
        raise ValueError(f"target_mrms_rel must be positive, got {target_mrms_rel!r}")
    a_min, a_max = 1e-5, 0.499
    tried: list[tuple[float, float, NDArray[np.float64]]] = []  # (alpha, mrms, vertices)
    alpha = 0.05
    for _ in range(max_evaluations):
        marked = embed_cho(vertices, faces, bits, key=key, alpha=alpha, centre=centre)
        m = mrms_rel(vertices, faces, marked, faces, samples=samples)
        tried.append((alpha, m, marked))
        if abs(m / target_mrms_rel - 1) <= tolerance:
            break
        below = [a for a, mm, _ in tried if mm < target_mrms_rel]
        above = [a for a, mm, _ in tried if mm > target_mrms_rel]
        lo, hi = max(below, default=a_min), min(above, default=a_max)
        if alpha >= a_max and m < target_mrms_rel:
            break  # the strongest mark is still below the target
        slope = 1.0
        if len(tried) >= 2:
            (a1, m1, _), (a2, m2, _) = tried[-2], tried[-1]
            if a1 != a2 and m1 > 0 and m2 > 0 and m1 != m2:
                slope = float(np.clip(np.log(m2 / m1) / np.log(a2 / a1), 0.2, 5.0))
        guess = alpha * (target_mrms_rel / max(m, 1e-300)) ** (1.0 / slope)
        if not lo < guess < hi:
            guess = float(np.sqrt(lo * hi))
        alpha = float(np.clip(guess, a_min, a_max))
    best = min(tried, key=lambda t: abs(np.log(t[1] / target_mrms_rel)) if t[1] > 0 else np.inf)
    return best[2], best[0]


def id_bits(ident: bytes, *, raw: bool = False) -> NDArray[np.uint8]:
    """The bits Cho carries for an 8-byte id: meshwm's 256 code bits, or the raw 64 bits."""
    if raw:
        if not isinstance(ident, (bytes, bytearray)) or len(ident) * 8 != ID_BITS:
            raise ValueError(f"an id is exactly {ID_BITS // 8} bytes")
        return np.unpackbits(np.frombuffer(bytes(ident), dtype=np.uint8))
    return encode_id(ident)


def cho_reads_id(
    marked_vertices: NDArray,
    faces: NDArray,
    ident: bytes,
    *,
    key: str | bytes,
    raw: bool = False,
    centre: str = "vertices",
) -> bool:
    """True when the received mesh gives back ``ident``.

    ``raw=False``: the 256 code bits decode (meshwm's :func:`decode_id`, with the bin margins
    as confidences, as meshwm gives its own) to the id; ``raw=True``: all 64 raw bits are right.
    """
    n_bits = ID_BITS if raw else PAYLOAD_BITS
    soft = extract_cho_soft(marked_vertices, faces, n_bits, key=key, centre=centre)
    bits = (soft > 0).astype(np.uint8)
    if raw:
        return bool(np.array_equal(bits, id_bits(ident, raw=True)))
    return decode_id(bits, soft) == bytes(ident).hex()


#: Attacks of the CLI: label -> (meshwm attack, options); issue #13's list.
ATTACKS: dict[str, tuple[str, dict[str, float | int]]] = {
    "none": ("none", {}),
    "similarity": ("similarity", {}),
    "noise": ("noise", {"amplitude": 0.001}),
    "laplacian5": ("laplacian", {"lam": 0.1, "iterations": 5}),
    "laplacian": ("laplacian", {"lam": 0.1, "iterations": 10}),
    "quantize": ("quantize", {"bits": 10}),
    "simplify": ("simplify", {"keep_fraction": 0.5}),
    "crop": ("crop", {"fraction": 0.1}),
}


def _report(path: Path, args: argparse.Namespace) -> None:
    from meshwm.attacks.registry import apply_attack
    from meshwm.mesh.io import read_mesh
    from meshwm.message.payload import parse_id

    v, f = read_mesh(path)
    ident = parse_id(args.id)
    bits = id_bits(ident, raw=args.raw)
    t0 = time.perf_counter()
    marked, alpha = calibrate_cho(
        v, f, bits, key=args.key, target_mrms_rel=args.target, centre=args.centre
    )
    seconds = time.perf_counter() - t0
    counts = bin_statistics(v, f, len(bits), centre=args.centre).counts
    mrms = mrms_rel(v, f, marked, f)
    print(
        f"{path.stem}: V={len(v)} bins={len(bits)} (vertices per bin min {counts.min()} median "
        f"{int(np.median(counts))}) alpha={alpha:.4g} mrms_rel={mrms:.3e} calib={seconds:.1f}s"
    )
    for name in args.attacks:
        attack, options = ATTACKS.get(name, (name, {}))
        if attack == "none":
            va, fa = marked, f
        else:
            va, fa = apply_attack(attack, marked, f, seed=args.seed, **options)
        got = extract_cho(va, fa, len(bits), key=args.key, centre=args.centre)
        ber = float(np.mean(got != bits))
        reads = cho_reads_id(va, fa, ident, key=args.key, raw=args.raw, centre=args.centre)
        print(f"  {name:<10} BER={ber:.4f} reads_id={reads}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("meshes", nargs="+", type=Path)
    parser.add_argument("--target", type=float, default=2e-4, help="MRMS / diagonal")
    parser.add_argument("--key", default="cho-key")
    parser.add_argument("--id", default="1234abcd", help="meshwm id (hex or short text)")
    parser.add_argument("--raw", action="store_true", help="carry the raw 64 id bits, 64 bins")
    parser.add_argument("--centre", choices=CENTRES, default="vertices")
    parser.add_argument("--seed", type=int, default=0, help="seed of the attacks")
    parser.add_argument(
        "--attacks",
        nargs="*",
        default=["none"],
        help=f"any of {', '.join(ATTACKS)} (or a meshwm attack with its defaults)",
    )
    args = parser.parse_args(argv)
    for path in args.meshes:
        _report(path, args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
