"""Tests for :mod:`meshwm.message.keying`: secrets derived from a key with HMAC-SHA256."""

from __future__ import annotations

import hashlib
import hmac

import numpy as np
import pytest

from meshwm.message.keying import key_bytes, keyed_permutation, keyed_uniform


def test_bytes_follow_the_documented_construction():
    """Golden value computed here with hmac directly: block k = HMAC(key, label 0x00 k)."""
    expected = b"".join(
        hmac.new(b"s3cret", b"slots\x00" + k.to_bytes(8, "big"), hashlib.sha256).digest()
        for k in range(3)
    )[:70]
    assert key_bytes("s3cret", "slots", 70) == expected
    assert key_bytes(b"s3cret", "slots", 70) == expected


def test_pinned_values_do_not_drift():
    """Pinned outputs: a change here changes every mark ever embedded."""
    assert key_bytes("secret", "demo", 4).hex() == "c55205ca"
    assert keyed_permutation("secret", "slots", 8).tolist() == [4, 1, 2, 5, 0, 6, 3, 7]
    np.testing.assert_allclose(
        keyed_uniform("secret", "dither", 3), [0.592072, 0.706346, 0.477165], rtol=0, atol=1e-6
    )


@pytest.mark.parametrize("count", [0, 1, 2, 17, 1000, 65536])
def test_permutation_is_a_permutation(count):
    perm = keyed_permutation("key", "slots", count)
    assert perm.dtype == np.int64
    assert np.array_equal(np.sort(perm), np.arange(count))


def test_permutation_positions_are_spread():
    """Over many keys, where element 0 lands is close to uniform (chi-square, 8 bins)."""
    landing = [int(np.argmax(keyed_permutation(f"k{i}", "slots", 8) == 0)) for i in range(4000)]
    counts = np.bincount(landing, minlength=8)
    chi2 = ((counts - 500) ** 2 / 500).sum()
    assert chi2 < 24.3  # 99.9 % point of chi-square with 7 degrees of freedom


def test_uniform_range_and_moments():
    u = keyed_uniform("key", "dither", 100_000)
    assert u.min() >= 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 0.005
    assert abs(u.var() - 1 / 12) < 0.002


@pytest.mark.parametrize(
    ("a", "b"),
    [(("key", "slots"), ("key2", "slots")), (("key", "slots"), ("key", "dither"))],
)
def test_other_key_or_purpose_gives_other_secrets(a, b):
    assert not np.array_equal(keyed_permutation(*a, 64), keyed_permutation(*b, 64))
    assert key_bytes(*a, 32) != key_bytes(*b, 32)


def test_same_key_same_secrets():
    assert np.array_equal(keyed_permutation("k", "p", 500), keyed_permutation("k", "p", 500))
    assert np.array_equal(keyed_uniform("k", "p", 500), keyed_uniform("k", "p", 500))


def test_prefix_property_of_the_stream():
    """More numbers extend the stream: the first ones do not change with the count."""
    assert np.array_equal(keyed_uniform("k", "p", 10), keyed_uniform("k", "p", 20)[:10])


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: key_bytes("", "p", 4), ValueError, "key must not be empty"),
        (lambda: key_bytes(5, "p", 4), TypeError, "key must be a string or bytes"),
        (lambda: keyed_uniform("k", "p", -1), ValueError, "count must lie in"),
        (lambda: keyed_permutation("k", "p", 2.5), TypeError, "count must be an integer"),
        (lambda: keyed_permutation("k", "p", True), TypeError, "count must be an integer"),
        (lambda: key_bytes("k", "p", 2**40), ValueError, "length must lie in"),
    ],
)
def test_bad_arguments(call, error, match):
    with pytest.raises(error, match=match):
        call()


@pytest.mark.parametrize("secret", [b"k", b"x" * 63, b"y" * 64, b"z" * 65, bytes(range(200))])
def test_bytes_are_hmacs_for_keys_shorter_and_longer_than_its_block(secret):
    # HMAC pads a key to 64 bytes and hashes a longer one first: spelled out, the same bytes.
    for length in (1, 31, 32, 33, 100):
        expected = b"".join(
            hmac.new(secret, b"p\x00" + k.to_bytes(8, "big"), hashlib.sha256).digest()
            for k in range(-(-length // 32))
        )[:length]
        assert key_bytes(secret, "p", length) == expected
    assert (
        key_bytes("é" * 40, "p", 8)
        == hmac.new(("é" * 40).encode(), b"p\x00" + bytes(8), hashlib.sha256).digest()[:8]
    )


@pytest.mark.parametrize("purpose", ["", "p", "meshwm/robust/v1/n1024/slots", "é" * 40])
@pytest.mark.parametrize("secret", [b"k", b"y" * 64, bytes(range(200))])
def test_bytes_are_the_per_block_hmacs_at_every_length(secret, purpose):
    """The stream is made by PBKDF2 with one iteration after a first HMAC block: block for
    block the construction's HMACs, across block boundaries and at thousands of blocks."""
    label = purpose.encode() + b"\x00"
    stream = b"".join(
        hmac.new(secret, label + k.to_bytes(8, "big"), hashlib.sha256).digest() for k in range(2000)
    )
    for length in (0, 1, 31, 32, 33, 63, 64, 65, 96, 1000, 32 * 2000 - 1, 32 * 2000):
        assert key_bytes(secret, purpose, length) == stream[:length]


@pytest.mark.parametrize("count", [0, 1, 2, 3, 100, 4097, 142_884])
@pytest.mark.parametrize("key", ["secret", b"\x00\x01"])
def test_permutation_is_the_draw_by_draw_fisher_yates(key, count):
    # The swaps' indices drawn at once where no draw is rejected: the same permutation as
    # drawing them one by one with rejection sampling.
    from meshwm.message.keying import _fisher_yates

    raw = key_bytes(key, "slots", 8 * (count + 16))
    np.testing.assert_array_equal(
        keyed_permutation(key, "slots", count), _fisher_yates(key, "slots", count, raw)
    )


@pytest.mark.parametrize("packed", [True, False])
@pytest.mark.parametrize("seed", range(6))
def test_swaps_applied_at_once_are_the_swaps_one_by_one(seed, packed, monkeypatch):
    from meshwm.message import keying
    from meshwm.message.keying import _swapped

    if not packed:  # the lexsort the largest counts take
        monkeypatch.setattr(keying, "_PACKED_BELOW", 0)

    rng = np.random.default_rng(seed)
    counts = [2, 3, 4, 5, 17, 64, 1000, int(rng.integers(2, 20_000))]
    for count in counts:
        uniform = [int(rng.integers(0, i + 1)) for i in range(count - 1, 0, -1)]
        cases = {
            "uniform": uniform,
            "identity": list(range(count - 1, 0, -1)),  # every position swapped with itself
            "to zero": [0] * (count - 1),  # one long chain through position 0
            "to next": [i - 1 for i in range(count - 1, 0, -1)],
            "low": [int(rng.integers(0, min(i, 3) + 1)) for i in range(count - 1, 0, -1)],
        }
        for name, draws in cases.items():
            perm = list(range(count))
            for i, j in zip(range(count - 1, 0, -1), draws, strict=True):
                perm[i], perm[j] = perm[j], perm[i]
            got = _swapped(np.asarray(draws, dtype=np.int64), count)
            assert got.tolist() == perm, (count, name)


def test_rejection_test_matches_integer_arithmetic():
    from meshwm.message.keying import _rejected

    top = 2**64 - 1
    bounds = [2, 3, 5, 7, 1 << 20, (1 << 20) + 1, 142_884, 2**63, 2**63 + 1, 2**64 - 1]
    for b in bounds:
        limit = (2**64 // b) * b
        for x in {0, b - 1, limit - 1, min(limit, top), top, max(limit - b, 0)}:
            got = _rejected(np.array([x], dtype=np.uint64), np.array([b], dtype=np.uint64))
            assert bool(got[0]) == (x >= limit), (x, b)
