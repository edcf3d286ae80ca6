"""ID payloads: parse, encode, correct errors, never report a wrong id."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.message.payload import (
    ID_BYTES,
    PAYLOAD_BITS,
    decode_id,
    encode_id,
    format_id,
    id_text,
    parse_id,
)


@pytest.mark.parametrize(
    "text, hexid",
    [
        ("0x0123456789abcdef", "0123456789abcdef"),
        ("0X0123456789ABCDEF", "0123456789abcdef"),
        ("0xff", "00000000000000ff"),
        # No 0x: text, even when it looks like hex (the one rule, issue 15).
        ("C0FFEE42", "4330464645453432"),
        ("ff", "6666000000000000"),
        ("build-42", "6275696c642d3432"),
        ("ü", "c3bc000000000000"),
    ],
)
def test_parse_id(text, hexid):
    assert parse_id(text).hex() == hexid


@pytest.mark.parametrize(
    "bad, message",
    [
        ("", "non-empty"),
        ("a much too long identifier", "at most 8 bytes"),
        ("0x0123456789abcdef0", "not 1 to 16 hex digits"),
        ("0xZZ", "not 1 to 16 hex digits"),
        ("0x", "not 1 to 16 hex digits"),
        ("0x12 ", "not 1 to 16 hex digits"),
        ("a\0b", "zero byte"),
    ],
)
def test_parse_id_refuses_with_one_line(bad, message):
    with pytest.raises(ValueError, match=message) as info:
        parse_id(bad)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    "text, shown",
    [
        ("VENDOR_A", '"VENDOR_A" (0x56454e444f525f41)'),
        ("ü", '"ü" (0xc3bc000000000000)'),
        ("0xC0FFEE42", "0x00000000c0ffee42"),
        ("0x4142434445464748", '"ABCDEFGH" (0x4142434445464748)'),
        ("0x0041", "0x0000000000000041"),  # zero bytes first: not text
        ("0x3078310000000000", "0x3078310000000000"),  # "0x1" would read back as hex
    ],
)
def test_format_id_shows_text_ids_as_text_and_hex(text, shown):
    ident = parse_id(text)
    assert format_id(ident) == shown
    assert format_id(ident.hex()) == shown


@pytest.mark.parametrize("text", ["VENDOR_A", "b-42", "ü", "C0FFEE42", "0xC0FFEE42", "0x01"])
def test_what_format_id_shows_parses_back_to_the_same_id(text):
    ident = parse_id(text)
    shown = id_text(ident)
    again = shown if shown is not None else "0x" + ident.hex()
    assert parse_id(again) == ident


@pytest.mark.parametrize("seed", range(20))
def test_round_trip_and_correction_of_random_byte_errors(seed):
    rng = np.random.default_rng(seed)
    ident = rng.bytes(ID_BYTES)
    bits = encode_id(ident)
    assert bits.shape == (PAYLOAD_BITS,)
    assert decode_id(bits) == ident.hex()
    # Up to 10 corrupted bytes are corrected without any confidence.
    noisy = bits.copy().reshape(-1, 8)
    for byte in rng.choice(32, size=10, replace=False):
        noisy[byte, rng.integers(8)] ^= 1
    assert decode_id(noisy.ravel()) == ident.hex()


def test_erasures_from_confidence_correct_more():
    rng = np.random.default_rng(5)
    ident = rng.bytes(ID_BYTES)
    bits = encode_id(ident)
    noisy = bits.copy().reshape(-1, 8)
    conf = np.ones((32, 8))
    bad = rng.choice(32, size=16, replace=False)  # beyond 10 errors: needs erasures
    for byte in bad:
        noisy[byte, 0] ^= 1
        conf[byte, 0] = 0.01  # the extractor was unsure of exactly those bits
    assert decode_id(noisy.ravel()) is None
    assert decode_id(noisy.ravel(), conf.ravel()) == ident.hex()


def _soft_read(bits: np.ndarray, spread: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A read through Gaussian noise: hard decisions and their soft values."""
    soft = (2.0 * bits - 1.0) + np.random.default_rng(seed).normal(scale=spread, size=bits.size)
    return (soft > 0).astype(np.uint8), soft


def test_scattered_wrong_bits_beyond_any_erasure_pattern_still_decode(monkeypatch):
    # A 7 % bit error rate hits 14-16 of the 32 bytes: more than any erasure pattern the
    # confidence finds corrects (28 of these 100 reads), not more than the code as a binary
    # code read by ordered statistics.
    import meshwm.message.payload as payload

    ident = bytes.fromhex("5ca1ab1e0ddba11f")
    bits = encode_id(ident)
    reads = [_soft_read(bits, 0.68, seed) for seed in range(100)]
    assert 0.06 < np.mean([np.mean(hard != bits) for hard, _ in reads]) < 0.08
    found = [decode_id(hard, soft) for hard, soft in reads]
    assert found.count(ident.hex()) >= 97 and set(found) <= {ident.hex(), None}
    monkeypatch.setattr(payload, "_ordered_statistics", lambda bits, confidence: None)
    by_erasures = [decode_id(hard, soft) for hard, soft in reads]
    assert by_erasures.count(ident.hex()) <= 40


@pytest.mark.parametrize("wrong, decodes", [(40, True), (48, True), (49, False), (80, False)])
def test_a_codeword_too_far_from_the_bits_read_is_not_an_id(wrong, decodes):
    # The least reliable bits wrong, the most reliable right: ordered statistics finds the
    # codeword, and takes it only within 48 wrong bits of the 256 (a read of noise lies about
    # 80 from every codeword it builds).
    rng = np.random.default_rng(wrong)
    ident = rng.bytes(ID_BYTES)
    bits = encode_id(ident)
    conf = rng.uniform(0.5, 1.0, PAYLOAD_BITS)
    flipped = rng.choice(PAYLOAD_BITS, size=wrong, replace=False)
    conf[flipped] = rng.uniform(0.0, 0.1, wrong)
    noisy = bits.copy()
    noisy[flipped] ^= 1
    assert decode_id(noisy, conf) == (ident.hex() if decodes else None)


@pytest.mark.slow
def test_random_bits_never_decode_to_an_id():
    rng = np.random.default_rng(0)
    found = [
        decode_id(rng.integers(0, 2, PAYLOAD_BITS), rng.normal(size=PAYLOAD_BITS))
        for _ in range(2000)
    ]
    assert found.count(None) == len(found)


def test_heavily_corrupted_id_is_none_not_wrong():
    rng = np.random.default_rng(1)
    ident = rng.bytes(ID_BYTES)
    bits = encode_id(ident)
    for trial in range(200):
        noisy = bits ^ (rng.random(PAYLOAD_BITS) < 0.15)  # ~ 23 of 32 bytes hit
        out = decode_id(noisy.astype(np.uint8), rng.random(PAYLOAD_BITS))
        assert out in (None, ident.hex()), trial


@pytest.mark.parametrize(
    "bits",
    [np.zeros(255, dtype=np.uint8), np.full(PAYLOAD_BITS, 2), np.zeros((16, 16), dtype=np.uint8)],
)
def test_decode_refuses_bad_input(bits):
    with pytest.raises(ValueError):
        decode_id(bits)


def test_encode_refuses_bad_input():
    with pytest.raises(ValueError):
        encode_id(b"short")
