"""Secrets derived from the user's key string, with HMAC-SHA256 only.

The paper's only secret is the number of Arnold iterations, and the Arnold map has a short
period (24 distinct scramblings of a 32×32 mark), so anyone can try them all.  meshwm derives
its secrets from a key string instead: the order in which carrier coefficients take the bits
(a permutation) and a dither per carrier (uniform numbers in [0, 1)).

Everything here is HMAC-SHA256 in counter mode (NIST SP 800-108 style) and integer arithmetic:
the same key gives the same bytes on any machine and with any NumPy, which a NumPy random
stream does not promise.  Each use has its own ``purpose`` label, so two secrets drawn from one
key are independent.
"""

from __future__ import annotations

import hashlib
import hmac

import numpy as np
from numpy.typing import NDArray

__all__ = ["key_bytes", "keyed_permutation", "keyed_uniform"]

_BLOCK = hashlib.sha256().digest_size  # 32 bytes per HMAC call


def _check_key(key: str | bytes) -> bytes:
    if isinstance(key, str):
        data = key.encode("utf-8")
    elif isinstance(key, (bytes, bytearray)):
        data = bytes(key)
    else:
        raise TypeError(f"key must be a string or bytes, got {type(key).__name__}")
    if not data:
        raise ValueError("key must not be empty")
    return data


def _check_count(count: int, name: str) -> int:
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(count).__name__}")
    if count < 0 or count > 2**31:
        raise ValueError(f"{name} must lie in [0, 2**31], got {count}")
    return int(count)


def key_bytes(key: str | bytes, purpose: str, length: int) -> bytes:
    """``length`` pseudo-random bytes for ``purpose``, derived from ``key``.

    Block k is ``HMAC-SHA256(key, purpose || 0x00 || k as 8 bytes big-endian)``.

    Parameters
    ----------
    key : str or bytes
        The user's secret (UTF-8 encoded when a string); must not be empty.
    purpose : str
        A label that separates independent secrets drawn from one key.
    length : int
        Number of bytes wanted.

    Returns
    -------
    bytes

    Examples
    --------
    >>> key_bytes("secret", "demo", 4).hex()
    'c55205ca'
    """
    secret = _check_key(key)
    length = _check_count(length, "length")
    label = purpose.encode("utf-8") + b"\x00"
    blocks = -(-length // _BLOCK)
    if blocks == 0:
        return b""
    # PBKDF2-HMAC-SHA256 with one iteration is block i = HMAC(key, salt || i as 4 bytes
    # big-endian) for i = 1, 2, ... (RFC 8018, 5.2): with the salt ``label || 4 zero bytes``
    # that is block k = i of the construction above, the counter's high half zero (k < 2**26
    # here).  So OpenSSL makes blocks 1.. in one call, without the GIL (igea's layout at
    # N = 1024: 2.3 MB in 0.073 -> 0.02 s), and block 0 is one HMAC.
    first = hmac.digest(secret, label + bytes(8), "sha256")
    if blocks == 1:
        return first[:length]
    rest = hashlib.pbkdf2_hmac("sha256", secret, label + bytes(4), 1, _BLOCK * (blocks - 1))
    return (first + rest)[:length]


def keyed_uniform(key: str | bytes, purpose: str, count: int) -> NDArray[np.float64]:
    """``count`` numbers uniform in [0, 1), 53 bits each, derived from ``key``.

    Examples
    --------
    >>> keyed_uniform("secret", "dither", 3).round(6)
    array([0.592072, 0.706346, 0.477165])
    """
    count = _check_count(count, "count")
    raw = np.frombuffer(key_bytes(key, purpose, 8 * count), dtype=">u8").astype(np.uint64)
    return (raw >> np.uint64(11)).astype(np.float64) / float(2**53)


def keyed_permutation(key: str | bytes, purpose: str, count: int) -> NDArray[np.int64]:
    """A permutation of ``0 .. count-1`` derived from ``key`` (Fisher-Yates, unbiased).

    Each swap index is drawn from 64 key bits by rejection sampling, so every permutation is
    equally likely up to the strength of HMAC-SHA256.

    Examples
    --------
    >>> keyed_permutation("secret", "slots", 8).tolist()
    [4, 1, 2, 5, 0, 6, 3, 7]
    """
    count = _check_count(count, "count")
    # Enough words for the swaps plus rejections (a rejection has probability < 2**-32 here).
    raw = key_bytes(key, purpose, 8 * (count + 16))
    x = np.frombuffer(raw, dtype=">u8").astype(np.uint64)[: max(count - 1, 0)]
    bound = np.arange(count, 1, -1, dtype=np.uint64)  # i + 1 for i = count - 1 .. 1
    if _rejected(x, bound).any():  # then the draws after it shift: swap by swap
        return _fisher_yates(key, purpose, count, raw)
    return _swapped((x % bound).astype(np.int64), count)


#: Counts below this pack (position, step) into one int64 key (count² < 2**63).
_PACKED_BELOW = 3_037_000_499


def _swapped(draws: NDArray[np.int64], count: int) -> NDArray[np.int64]:
    """``0 .. count-1`` after Fisher-Yates' swaps: for ``i = count-1 .. 1``, positions ``i``
    and ``draws[count-1-i]`` (at most ``i``) exchanged; the same permutation as swapping one
    by one, without a Python loop (142k slots, N = 1024: 0.05-0.1 s -> 0.02 s).

    Position ``i`` is final after its swap, and takes what position ``j = draws[..]`` holds
    then: ``j``'s value, or, where a swap ``k > i`` wrote ``j`` before (the last of them is the
    smallest such ``k``), what position ``k`` held just before its own swap.  That value,
    ``W(k)``, is in turn ``k``'s own, or ``W`` of the first swap after ``k`` that wrote ``k``:
    a chain of increasing steps, followed to its end by pointer doubling.  Position 0 is as a
    swap of 0 with itself.
    """
    if count < 2:
        return np.arange(count, dtype=np.int64)
    target = np.empty(count, dtype=np.int64)  # the position swap i exchanges with i
    target[0] = 0
    target[1:] = draws[::-1]
    steps = np.arange(count, dtype=np.int64)
    # The swaps by position written, each position's in increasing step order: one sort of a
    # packed key where count² fits in int64 (any layout's count does), else a lexsort.
    if count < _PACKED_BELOW:
        packed = np.sort(target * count + steps)
        written, step = packed // count, packed % count
    else:
        order = np.lexsort((steps, target))
        written, step = target[order], steps[order]
    same = written[1:] == written[:-1]
    # later[i]: the smallest swap k > i that wrote position target[i], or -1.
    later = np.full(count, -1, dtype=np.int64)
    later[step[:-1][same]] = step[1:][same]
    # chain[k]: the first swap after k that wrote position k, or k itself (none): a swap k'
    # writes k only if k' >= k, and k' = k leaves it as it is.
    after = np.flatnonzero(step > written)
    head = np.ones(len(after), dtype=bool)
    head[1:] = written[after[1:]] != written[after[:-1]]
    chain = steps.copy()
    chain[written[after[head]]] = step[after[head]]
    while True:  # pointer doubling: each chain's end, W
        jumped = chain[chain]
        if np.array_equal(jumped, chain):
            break
        chain = jumped
    return np.where(later >= 0, chain[np.maximum(later, 0)], target)


def _rejected(x: NDArray[np.uint64], bound: NDArray[np.uint64]) -> NDArray[np.bool_]:
    """Where ``x >= (2**64 // bound) * bound``: a draw :func:`_fisher_yates` rejects.

    With ``M = 2**64 - 1 = F * bound + r``: ``2**64 // bound`` is ``F``, or ``F + 1`` where
    ``r = bound - 1`` (``bound`` divides ``2**64``: nothing is rejected); ``x // bound``
    never exceeds ``F``.
    """
    top = np.uint64(2**64 - 1)
    return (x // bound == top // bound) & (top % bound != bound - np.uint64(1))


def _fisher_yates(key: str | bytes, purpose: str, count: int, raw: bytes) -> NDArray[np.int64]:
    """:func:`keyed_permutation` draw by draw, rejections included (``raw``: its first words)."""
    perm = list(range(count))
    words = np.frombuffer(raw, dtype=">u8").tolist()
    w = 0
    for i in range(count - 1, 0, -1):
        bound = i + 1
        limit = (2**64 // bound) * bound
        while True:
            if w == len(words):
                words += np.frombuffer(
                    key_bytes(key, f"{purpose}/more{w}", 8 * 64), dtype=">u8"
                ).tolist()
            x = words[w]
            w += 1
            if x < limit:
                break
        j = x % bound
        perm[i], perm[j] = perm[j], perm[i]
    return np.asarray(perm, dtype=np.int64)
