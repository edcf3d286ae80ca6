"""ID payloads: parse, encode, correct errors, never report a wrong id."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.message.payload import ID_BYTES, PAYLOAD_BITS, decode_id, encode_id, parse_id


@pytest.mark.parametrize(
    "text, hexid",
    [
        ("0x0123456789abcdef", "0123456789abcdef"),
        ("0123456789ABCDEF", "0123456789abcdef"),
        ("ff", "00000000000000ff"),
        ("build-42", "6275696c642d3432"),
        ("ü", "c3bc000000000000"),
    ],
)
def test_parse_id(text, hexid):
    assert parse_id(text).hex() == hexid


@pytest.mark.parametrize("bad", ["", "a much too long identifier", "0x0123456789abcdef0"])
def test_parse_id_refuses(bad):
    with pytest.raises(ValueError):
        parse_id(bad)


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


def test_random_bits_never_decode_to_an_id():
    rng = np.random.default_rng(0)
    found = [
        decode_id(rng.integers(0, 2, PAYLOAD_BITS), rng.normal(size=PAYLOAD_BITS))
        for _ in range(500)
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
