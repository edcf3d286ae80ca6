"""ID payloads: a 64-bit identifier with a checksum, protected by a Reed-Solomon code.

A logo answers "is this ours?"; a studio also wants "whose copy is it?": a customer or build id
embedded instead of the logo (``meshwm embed --id``).  An id must come back exactly or not at
all, so it is wrapped twice:

1. **Checksum.** The 8 id bytes get their CRC-32 (:func:`zlib.crc32`, 4 bytes).  A decode
   whose CRC does not match is *no id* (``None``), never a wrong one: a random 12-byte string
   passes with probability 2⁻³².
2. **Error correction.** The 12 bytes are encoded with Reed-Solomon over GF(256) with 20 parity
   symbols (``reedsolo``): 32 bytes, 256 bits, any 10 wrong bytes corrected.  Before decoding,
   the bytes whose bits the extractor was least sure of are declared *erasures* when there is
   room (an RS code corrects twice as many erasures as errors).

The 256 code bits are the payload the watermark carries (:mod:`meshwm.profiles.robust`: at N = 256
about 31 coefficients per bit).  Extraction always tries to read an id; the CRC decides.

References
----------
.. [1] I. S. Reed, G. Solomon, "Polynomial codes over certain finite fields", J. SIAM 8(2),
   1960.
"""

from __future__ import annotations

import functools
import re
import zlib

import numpy as np
import reedsolo
from numpy.typing import NDArray

__all__ = [
    "ID_BITS",
    "ID_BYTES",
    "PAYLOAD_BITS",
    "decode_id",
    "encode_id",
    "format_id",
    "id_text",
    "parse_id",
]

#: Length of an identifier.
ID_BYTES = 8
ID_BITS = 8 * ID_BYTES
_CRC_BYTES = 4
_PARITY = 20
#: Bits the watermark carries for an id.
PAYLOAD_BITS = 8 * (ID_BYTES + _CRC_BYTES + _PARITY)
_HEX_DIGITS = re.compile(r"[0-9a-fA-F]{1,16}")


@functools.lru_cache(maxsize=1)
def _codec() -> reedsolo.RSCodec:
    """The Reed-Solomon codec, built once (its Galois-field tables cost a quarter of a
    surface-reader null trial when rebuilt per decode); the only codec meshwm makes."""
    return reedsolo.RSCodec(_PARITY)


def parse_id(text: str) -> bytes:
    """The 8 id bytes of a command-line id: ``0x`` then hex digits, or else text.

    One rule, no guessing: an id that starts with ``0x`` (or ``0X``) is hexadecimal, 1 to 16
    digits, read as a big-endian number and left-padded with zero bytes; anything else is UTF-8
    text of at most 8 bytes, right-padded with zero bytes.  So ``C0FFEE42`` is the 8 letters
    ``C0FFEE42``, not a number; write ``0xC0FFEE42`` for the number.  A text id cannot start
    with ``0x`` (give such an id in hex) and cannot contain a zero byte.

    Parameters
    ----------
    text : str
        The id as typed.

    Returns
    -------
    bytes
        Exactly :data:`ID_BYTES` bytes.

    Raises
    ------
    ValueError
        Empty, ``0x`` followed by anything but 1 to 16 hex digits, text longer than 8 bytes
        in UTF-8, or text with a zero byte.  The message is one line.

    Examples
    --------
    >>> parse_id("0xC0FFEE").hex(), parse_id("build-42").hex()
    ('0000000000c0ffee', '6275696c642d3432')
    >>> parse_id("C0FFEE42") == b"C0FFEE42"
    True
    >>> parse_id("0xZZ")
    Traceback (most recent call last):
    ...
    ValueError: id '0xZZ' starts with 0x but 'ZZ' is not 1 to 16 hex digits (0-9, a-f)
    """
    if not isinstance(text, str) or not text:
        raise ValueError("an id must be a non-empty string: 0x and hex digits, or short text")
    if text[:2] in ("0x", "0X"):
        digits = text[2:]
        if not _HEX_DIGITS.fullmatch(digits):
            raise ValueError(
                f"id {text!r} starts with 0x but {digits!r} is not 1 to 16 hex digits (0-9, a-f)"
            )
        return int(digits, 16).to_bytes(ID_BYTES, "big")
    raw = text.encode("utf-8")
    if len(raw) > ID_BYTES:
        raise ValueError(
            f"id {text!r} is {len(raw)} bytes of text; at most {ID_BYTES} bytes, or 0x and up "
            "to 16 hex digits"
        )
    if b"\0" in raw:
        raise ValueError(f"id {text!r} contains a zero byte; give it in hex (0x...)")
    return raw.ljust(ID_BYTES, b"\0")


def id_text(ident: bytes | str) -> str | None:
    """The id as text, when it is printable text (what :func:`parse_id` made of text), else None.

    Parameters
    ----------
    ident : bytes or str
        The 8 id bytes, or their 16 hex digits (as :func:`decode_id` returns them).

    Examples
    --------
    >>> id_text(b"VENDOR_A"), id_text("6275696c642d3432"), id_text(bytes.fromhex("c0ffee42" * 2))
    ('VENDOR_A', 'build-42', None)
    """
    raw = bytes.fromhex(ident) if isinstance(ident, str) else bytes(ident)
    stripped = raw.rstrip(b"\0")
    if not stripped or b"\0" in stripped:
        return None
    try:
        text = stripped.decode("utf-8")
    except UnicodeDecodeError:
        return None
    if not text.isprintable() or text[:2] in ("0x", "0X"):
        return None
    return text


def format_id(ident: bytes | str) -> str:
    """The id as a person reads it: ``"TEXT" (0xHEX)`` for a text id, else ``0xHEX``.

    Both forms can be typed back to ``--id`` (the quoted text without its quotes).

    Examples
    --------
    >>> format_id(parse_id("VENDOR_A")), format_id(parse_id("0xC0FFEE42"))
    ('"VENDOR_A" (0x56454e444f525f41)', '0x00000000c0ffee42')
    """
    raw = bytes.fromhex(ident) if isinstance(ident, str) else bytes(ident)
    text = id_text(raw)
    return f'"{text}" (0x{raw.hex()})' if text is not None else f"0x{raw.hex()}"


def encode_id(ident: bytes) -> NDArray[np.uint8]:
    """The :data:`PAYLOAD_BITS` code bits of an 8-byte id (CRC-32, then Reed-Solomon).

    Examples
    --------
    >>> bits = encode_id(parse_id("0x1234abcd"))
    >>> bits.shape, decode_id(bits)
    ((256,), '000000001234abcd')
    """
    if not isinstance(ident, (bytes, bytearray)) or len(ident) != ID_BYTES:
        raise ValueError(f"an id is exactly {ID_BYTES} bytes")
    message = bytes(ident) + zlib.crc32(ident).to_bytes(_CRC_BYTES, "big")
    code = bytes(_codec().encode(message))
    return np.unpackbits(np.frombuffer(code, dtype=np.uint8))


def decode_id(bits: NDArray, confidence: NDArray | None = None) -> str | None:
    """The id as 16 hex digits, or ``None`` when the code bits do not decode to a valid id.

    Parameters
    ----------
    bits : (PAYLOAD_BITS,) array of 0/1
        Hard decisions.
    confidence : (PAYLOAD_BITS,) array of float, optional
        Per-bit reliability (any sign); the least reliable bytes are tried as erasures when the
        plain decode fails.
    """
    bits = np.asarray(bits)
    if bits.shape != (PAYLOAD_BITS,) or not np.all((bits == 0) | (bits == 1)):
        raise ValueError(f"need {PAYLOAD_BITS} bits of 0/1, got shape {bits.shape}")
    code = bytearray(np.packbits(bits.astype(np.uint8)).tobytes())
    attempts: list[list[int]] = [[]]
    if confidence is not None:
        conf = np.abs(np.asarray(confidence, dtype=np.float64)).reshape(-1, 8).min(axis=1)
        order = [int(k) for k in np.argsort(conf, kind="stable")]
        attempts += [order[:k] for k in (4, 8, 12, 16, _PARITY)]
    for erase in attempts:
        try:
            message = bytes(_codec().decode(bytearray(code), erase_pos=erase or None)[0])
        except reedsolo.ReedSolomonError:
            continue
        ident, crc = message[:ID_BYTES], message[ID_BYTES:]
        if zlib.crc32(ident).to_bytes(_CRC_BYTES, "big") == crc:
            return ident.hex()
    return None
