"""The detection decision: a binomial p-value, Bonferroni over the hypotheses tried, one Verdict.

Under the null hypothesis (no mark, or another key) the keyed dither makes every extracted bit a
fair coin, so the number of bits that agree with the expected message is Binomial(n, 1/2).
That holds for the bits an image *read*; a bit with zero confidence was not read (no slot
carries it, or none of its slots has samples) and reads 0 whatever the key, so it is left out
(:func:`read_p_value`).  A mark (a logo) is tested against chance *given how many 1s it and the
read have* (:func:`mark_p_value`): two sparse drawings agree on most pixels, so a copy carrying
one must not verify as carrying the other.
Extraction may try several hypotheses (grid orientations, offsets, sizes, gains, readers) and
keeps the best; dividing the false-positive budget by their number keeps the overall chance of a
false "present" on an unmarked mesh below ``fpr``.  Every caller that says "present" or "absent"
decides here, with :func:`decide`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "DEFAULT_FPR",
    "Verdict",
    "decide",
    "detection_p_value",
    "is_detected",
    "mark_p_value",
    "read_p_value",
]

#: The false-positive rate ``verify`` works at unless told otherwise.
DEFAULT_FPR = 1e-6


class Verdict(NamedTuple):
    """The decision on one extraction.

    Attributes
    ----------
    detected : bool
        ``p_value < threshold`` (and, for an id, the id read back is the one expected).
    p_value : float
        The binomial tail of the best hypothesis.
    hypotheses : int
        How many hypotheses extraction tried (the Bonferroni factor), at least 1.
    threshold : float
        ``fpr / hypotheses``.
    """

    detected: bool
    p_value: float
    hypotheses: int
    threshold: float


def detection_p_value(agreeing: int, total: int) -> float:
    """P(at least ``agreeing`` of ``total`` fair coin flips come up right): the binomial tail.

    Under the null hypothesis (no mark, or another key) the keyed dither makes every extracted
    bit a fair coin, so this is the probability of a match at least this good by chance.

    Examples
    --------
    >>> detection_p_value(10, 10) == 0.5**10
    True
    """
    from scipy.stats import binom

    if not 0 <= agreeing <= total or total < 1:
        raise ValueError(f"need 0 <= agreeing <= total and total >= 1, got {agreeing}, {total}")
    return float(binom.sf(agreeing - 1, total, 0.5))


def read_p_value(expected: ArrayLike, bits: ArrayLike, confidence: ArrayLike) -> float:
    """The p-value of a read against the bits expected, over the bits it read.

    A decoder gives a bit zero confidence when it read nothing of it: no slot of the image
    carries it (the radial carrier's image at N = 128 has none for a 32×32 logo), every one of
    its slots lies where the image has no samples, or the read as a whole is no better than
    chance (the radial carrier scales its confidences by its reliability, 0 at chance).  Such
    a bit reads 0 whatever the key, which is not a fair coin: a logo is mostly 0s (the bundled
    one 64 %), and an empty read of an unmarked triangle soup agreed with it at p 2.8e-19.
    Those bits are left out; a read with none left is no evidence (1.0).

    Parameters
    ----------
    expected, bits : (n,) array_like of 0/1
        The bits looked for and the bits read.
    confidence : (n,) array_like of float
        The decoder's soft confidence per bit (its sign is the bit's, its size how sure).

    Returns
    -------
    float
        :func:`detection_p_value` of the read bits that agree, or 1.0 when none was read.

    Examples
    --------
    >>> read_p_value([1, 0, 1, 0], [1, 0, 0, 0], [0.9, 0.8, 0.0, 0.0]) == 0.5**2
    True
    >>> read_p_value([0, 0], [0, 0], [0.0, 0.0])
    1.0
    """
    want, got = _read_bits(expected, bits, confidence)
    if len(want) == 0:
        return 1.0
    return detection_p_value(int(np.sum(want == got)), len(want))


def _read_bits(
    expected: ArrayLike, bits: ArrayLike, confidence: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """The expected and read bits where the read has nonzero confidence."""
    want = np.asarray(expected).ravel()
    got = np.asarray(bits).ravel()
    read = np.asarray(confidence, dtype=np.float64).ravel() != 0
    if not want.shape == got.shape == read.shape:
        raise ValueError(
            f"expected, bits and confidence differ in length: {len(want)}, {len(got)}, {len(read)}"
        )
    return want[read], got[read]


def mark_p_value(expected: ArrayLike, bits: ArrayLike, confidence: ArrayLike) -> float:
    """The p-value of a read against an expected *mark*, given both their counts of 1s.

    A drawing is mostly background: two thin 32×32 drawings with 6 % ink each (a plus and a
    cross) agree on 88 % of their pixels, so the plain binomial tail (:func:`read_p_value`)
    said a copy marked with the one carried the other (p 8.7e-149), and a blank mark too.  Here
    the agreement is compared with what a read independent of the mark gives with the same
    counts of 1s (the one-sided hypergeometric tail of the 1s they share: Fisher's exact
    test), over the bits read (nonzero confidence).  Under the null (no mark, or another key)
    the read bits are fair coins independent of the mark, so this is a valid p-value as the
    binomial's is, conditioned on the margins; a mark or a read with no 1s or no 0s tells
    nothing (1.0).  For the bundled logo (36 % ink) it costs little: a read with 35 % of its
    bits wrong gives 2.0e-20 against the binomial's 2.1e-22.

    Parameters
    ----------
    expected, bits : (n,) array_like of 0/1
        The mark's bits looked for and the bits read (in the same order).
    confidence : (n,) array_like of float
        The decoder's soft confidence per bit; bits of zero confidence were not read.

    Returns
    -------
    float
        ``P(X >= shared 1s)`` for ``X`` hypergeometric, or 1.0 when nothing can be told.

    Examples
    --------
    >>> plus = [1, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    >>> cross = [0, 1, 0, 0, 0, 0, 0, 0, 0, 0]
    >>> round(read_p_value(plus, cross, [1.0] * 10), 4), mark_p_value(plus, cross, [1.0] * 10)
    (0.0547, 1.0)
    >>> round(mark_p_value(plus, plus, [1.0] * 10), 4)  # its one 1 among 10 where it should be
    0.1
    """
    from scipy.stats import hypergeom

    want, got = _read_bits(expected, bits, confidence)
    total, marked, drawn = len(want), int(want.sum()), int(got.sum())
    if min(marked, drawn) == 0 or max(marked, drawn) == total:
        return 1.0
    shared = int(np.sum((want == 1) & (got == 1)))
    return float(min(1.0, hypergeom.sf(shared - 1, total, marked, drawn)))


def is_detected(p_value: float, *, fpr: float = DEFAULT_FPR, hypotheses: int = 1) -> bool:
    """The verify decision: present when ``p_value < fpr / hypotheses`` (Bonferroni).

    Examples
    --------
    >>> is_detected(1e-9, fpr=1e-6), is_detected(1e-9, fpr=1e-6, hypotheses=10_000)
    (True, False)
    """
    if not 0.0 < fpr < 1.0:
        raise ValueError(f"fpr must lie in (0, 1), got {fpr}")
    if hypotheses < 1:
        raise ValueError(f"hypotheses must be >= 1, got {hypotheses}")
    return bool(p_value < fpr / hypotheses)


def decide(
    report: Mapping[str, Any],
    *,
    fpr: float = DEFAULT_FPR,
    found_id: str | None = None,
    expected_id: str | None = None,
) -> Verdict:
    """Decide from an extraction report (its ``p_value`` and ``hypotheses``).

    Parameters
    ----------
    report : mapping
        An extraction report with ``p_value`` and, optionally, ``hypotheses`` (default 1).
    fpr : float, optional
        The false-positive rate, in (0, 1).  Default :data:`DEFAULT_FPR`.
    found_id, expected_id : str or None, optional
        For an id: the id read back (hex, ``None`` when none decoded) and the one expected.  When
        ``expected_id`` is given, detection also needs ``found_id == expected_id``.

    Examples
    --------
    >>> decide({"p_value": 1e-12, "hypotheses": 100}).detected
    True
    >>> decide({"p_value": 1e-12}, found_id=None, expected_id="c0ffee42").detected
    False
    """
    p_value = float(report["p_value"])
    hypotheses = int(report.get("hypotheses", 1))
    detected = is_detected(p_value, fpr=fpr, hypotheses=hypotheses)
    if expected_id is not None:
        detected = detected and found_id == expected_id
    return Verdict(detected, p_value, hypotheses, fpr / hypotheses)
