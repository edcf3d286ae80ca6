"""Tests for :mod:`meshwm.detect`: the binomial p-value, Bonferroni and the Verdict.

The reference is scipy's exact ``binomtest`` (for the binomial tail).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.stats import binomtest

from meshwm.detect import (
    decide,
    detection_p_value,
    is_detected,
    mark_p_value,
    read_p_value,
)

# --- detection_p_value ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("agreeing", "total"),
    [(0, 1), (1, 1), (0, 10), (5, 10), (7, 10), (10, 10), (512, 1024), (600, 1024), (1000, 1024)],
)
def test_detection_p_value_is_the_binomial_tail(agreeing, total):
    expected = binomtest(agreeing, total, 0.5, alternative="greater").pvalue
    assert_allclose(detection_p_value(agreeing, total), expected, rtol=1e-9, atol=0)


def test_detection_p_value_edges():
    assert detection_p_value(0, 50) == 1.0
    assert detection_p_value(50, 50) == 0.5**50


def test_detection_p_value_falls_as_agreement_grows():
    # n = 32: every tail, down to 1 - 2**-32, is distinct in float64.
    p = np.array([detection_p_value(k, 32) for k in range(33)])
    assert np.all(np.diff(p) < 0)


@pytest.mark.parametrize(("agreeing", "total"), [(-1, 10), (11, 10), (0, 0), (1, 0)])
def test_detection_p_value_refuses_impossible_counts(agreeing, total):
    with pytest.raises(ValueError, match="need 0 <= agreeing <= total"):
        detection_p_value(agreeing, total)


# --- decide ---------------------------------------------------------------------------------


def test_decide_divides_the_budget_by_the_hypotheses():
    report = {"p_value": 1e-9, "hypotheses": 100}
    verdict = decide(report, fpr=1e-6)
    assert verdict.detected and verdict.threshold == 1e-8 and verdict.hypotheses == 100
    assert not decide({"p_value": 1e-9, "hypotheses": 10_000}, fpr=1e-6).detected
    assert decide({"p_value": 1e-9}).hypotheses == 1


@pytest.mark.parametrize(
    ("found", "detected"), [("c0ffee42", True), ("c0ffee43", False), (None, False)]
)
def test_decide_needs_the_expected_id(found, detected):
    report = {"p_value": 1e-30, "hypotheses": 1}
    assert decide(report, found_id=found, expected_id="c0ffee42").detected is detected
    assert decide(report, found_id=found).detected  # no id expected: the p-value decides


@pytest.mark.parametrize(("fpr", "hypotheses"), [(0.0, 1), (1.0, 1), (1e-6, 0)])
def test_is_detected_refuses_bad_options(fpr, hypotheses):
    with pytest.raises(ValueError, match="must"):
        is_detected(0.5, fpr=fpr, hypotheses=hypotheses)


# --- read_p_value ---------------------------------------------------------------------------


def test_read_p_value_counts_only_the_bits_read():
    rng = np.random.default_rng(5)
    expected = rng.integers(0, 2, 200)
    bits = expected.copy()
    bits[:40] ^= 1  # 40 wrong among the read bits
    confidence = rng.uniform(0.1, 1.0, 200) * np.where(bits == 1, -1, 1)
    confidence[150:] = 0.0  # 50 bits no slot carried
    bits[150:] = 0
    assert read_p_value(expected, bits, confidence) == detection_p_value(110, 150)
    # Every bit read: the plain binomial tail of the whole read.
    confidence[150:] = 0.5
    agree = int(np.sum(bits == expected))
    assert read_p_value(expected, bits, confidence) == detection_p_value(agree, 200)


def test_an_empty_read_is_no_evidence_against_a_mostly_zero_logo():
    # A decoder with no slot for the bits reads 0s at zero confidence; a logo that is 64 % 0s
    # agreed with that at p 2.8e-19 when every bit counted.
    expected = np.r_[np.zeros(654, dtype=np.uint8), np.ones(370, dtype=np.uint8)]
    zeros = np.zeros(1024, dtype=np.uint8)
    assert detection_p_value(int(np.sum(zeros == expected)), 1024) < 1e-18
    assert read_p_value(expected, zeros, np.zeros(1024)) == 1.0


def test_read_p_value_refuses_arrays_of_different_lengths():
    with pytest.raises(ValueError, match="differ in length"):
        read_p_value([0, 1, 1], [0, 1], [0.5, 0.5])


# --- mark_p_value ---------------------------------------------------------------------------


def _thin(kind: str) -> np.ndarray:
    yy, xx = np.mgrid[:32, :32]
    if kind == "plus":
        return ((yy == 16) | (xx == 16)).astype(np.uint8).ravel()
    return ((yy == xx) | (yy == 31 - xx)).astype(np.uint8).ravel()


def test_a_sparse_mark_read_does_not_verify_as_another_sparse_mark():
    # Two 6 %-ink drawings agree on 88 % of their pixels: the binomial tail calls that a
    # detection at any threshold; given the counts of 1s it is what independence gives.
    plus, cross = _thin("plus"), _thin("cross")
    sure = np.ones(1024)
    assert read_p_value(cross, plus, sure) < 1e-100
    assert mark_p_value(cross, plus, sure) > 0.01
    assert mark_p_value(plus, plus, sure) < 1e-90  # the mark itself, read exactly
    assert mark_p_value(np.zeros(1024), plus, sure) == 1.0  # a blank mark tells nothing
    assert mark_p_value(plus, np.ones(1024), sure) == 1.0  # nor a read of all 1s


def test_mark_p_value_holds_its_level_on_reads_of_noise():
    # Fair coins against a sparse mark and against a balanced one: P(p < a) <= a (it is
    # conservative, the tail being discrete), as for the binomial.
    rng = np.random.default_rng(11)
    for mark in (_thin("plus"), rng.integers(0, 2, 1024)):
        p = np.array(
            [mark_p_value(mark, rng.integers(0, 2, 1024), np.ones(1024)) for _ in range(2000)]
        )
        for a in (0.01, 0.05, 0.2):
            assert np.mean(p < a) <= a + 3 * np.sqrt(a * (1 - a) / 2000)
        assert np.mean(p < 0.2) > 0.1  # and not a test that never fires


def test_mark_p_value_leaves_out_the_bits_not_read():
    plus = _thin("plus")
    conf = np.ones(1024)
    read = plus.copy()
    read[:512] = 0
    conf[:512] = 0.0  # half the image had no samples
    assert mark_p_value(plus, read, conf) == mark_p_value(plus[512:], plus[512:], np.ones(512))
