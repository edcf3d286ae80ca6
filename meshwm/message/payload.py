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

import re
import zlib

import numpy as np
import reedsolo
from numpy.typing import NDArray

__all__ = ["ID_BITS", "ID_BYTES", "PAYLOAD_BITS", "decode_id", "encode_id", "parse_id"]

#: Length of an identifier.
ID_BYTES = 8
ID_BITS = 8 * ID_BYTES
_CRC_BYTES = 4
_PARITY = 20
#: Bits the watermark carries for an id.
PAYLOAD_BITS = 8 * (ID_BYTES + _CRC_BYTES + _PARITY)
_HEX = re.compile(r"(?:0x)?([0-9a-fA-F]{1,16})")


def _codec() -> reedsolo.RSCodec:
    return reedsolo.RSCodec(_PARITY)


def parse_id(text: str) -> bytes:
    """The 8 id bytes of a command-line id: hex (``0x`` optional, up to 16 digits) or text.

    Hex is read as a big-endian number, left-padded with zeros; anything else is taken as UTF-8
    text of at most 8 bytes, right-padded with zero bytes.  Reported back as 16 hex digits.

    Examples
    --------
    >>> parse_id("0xC0FFEE").hex(), parse_id("build-42").hex()
    ('0000000000c0ffee', '6275696c642d3432')
    """
    if not isinstance(text, str) or not text:
        raise ValueError("an id must be a non-empty string (hex digits or short text)")
    m = _HEX.fullmatch(text)
    if m:
        return int(m.group(1), 16).to_bytes(ID_BYTES, "big")
    raw = text.encode("utf-8")
    if len(raw) > ID_BYTES:
        raise ValueError(
            f"id {text!r} is {len(raw)} bytes; at most {ID_BYTES} bytes of text or 16 hex digits"
        )
    return raw.ljust(ID_BYTES, b"\0")


def encode_id(ident: bytes) -> NDArray[np.uint8]:
    """The :data:`PAYLOAD_BITS` code bits of an 8-byte id (CRC-32, then Reed-Solomon).

    Examples
    --------
    >>> bits = encode_id(parse_id("1234abcd"))
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
