"""ID payloads: a 64-bit identifier with a checksum, protected by a Reed-Solomon code.

A logo answers "is this ours?"; a studio also wants "whose copy is it?": a customer or build id
embedded instead of the logo (``meshwm embed --id``).  An id must come back exactly or not at
all, so it is wrapped twice, and read with the extractor's confidence:

1. **Checksum.** The 8 id bytes get their CRC-32 (:func:`zlib.crc32`, 4 bytes).  A decode
   whose CRC does not match is *no id* (``None``), never a wrong one: a random 12-byte string
   passes with probability 2⁻³².
2. **Error correction.** The 12 bytes are encoded with Reed-Solomon over GF(256) with 20 parity
   symbols (``reedsolo``): 32 bytes, 256 bits, any 10 wrong bytes corrected.  Before decoding,
   the bytes whose bits the extractor was least sure of are declared *erasures* when there is
   room (an RS code corrects twice as many erasures as errors).
3. **Soft decision.** When no erasure pattern decodes, the code is decoded as the binary code
   it also is (RS over GF(2⁸) is linear over GF(2): a 96 × 256 generator matrix) by ordered
   statistics: the 96 most reliable independent bits fix a codeword, and each of them flipped
   in turn gives 96 more; one whose CRC matches and which differs from the bits read in at most
   :data:`_OSD_MOST_WRONG` of them is the id.  A byte code spends a whole byte on one wrong bit:
   scattered errors at a 6-7 % bit error rate (14-16 wrong bytes of 32) are beyond any erasure
   pattern, not beyond the code.

The 256 code bits are the payload the watermark carries (:mod:`meshwm.profiles.robust`: at N = 256
about 31 coefficients per bit).  Extraction always tries to read an id; the CRC decides.

References
----------
.. [1] I. S. Reed, G. Solomon, "Polynomial codes over certain finite fields", J. SIAM 8(2),
   1960.
.. [2] M. P. C. Fossorier, S. Lin, "Soft-decision decoding of linear block codes based on
   ordered statistics", IEEE Trans. Inf. Theory 41(5), 1995.
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
#: The message bits (id and CRC) the code protects.
_MESSAGE_BITS = 8 * (ID_BYTES + _CRC_BYTES)
#: An ordered-statistics codeword is an id only if it differs from the bits read in at most
#: this many of the 256 (19 %).  A read of noise differs from every codeword the decoder
#: builds in about 80 (the 160 bits outside its basis at chance, a standard deviation of 6.3):
#: the bound stands 5 of them off, on top of the CRC's 2⁻³²; the reads it decodes differ in
#: 15-19 (2026-12-07 (33)).
_OSD_MOST_WRONG = 48


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
        plain decode fails, then the most reliable bits fix the codeword (ordered statistics,
        Fossorier and Lin 1995, with at most :data:`_OSD_MOST_WRONG` of the bits read wrong).
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
    if confidence is None:
        return None
    return _ordered_statistics(bits.astype(np.uint8), np.asarray(confidence, dtype=np.float64))


@functools.lru_cache(maxsize=1)
def _generator() -> NDArray[np.uint8]:
    """The code's binary generator matrix, 96 × 256: row i is the code of message bit i alone
    (the code is systematic: its first 96 columns are the identity)."""
    rows = np.zeros((_MESSAGE_BITS, PAYLOAD_BITS), dtype=np.uint8)
    for i in range(_MESSAGE_BITS):
        unit = np.zeros(_MESSAGE_BITS, dtype=np.uint8)
        unit[i] = 1
        code = bytes(_codec().encode(bytearray(np.packbits(unit).tobytes())))
        rows[i] = np.unpackbits(np.frombuffer(code, dtype=np.uint8))
    rows.setflags(write=False)
    return rows


def _ordered_statistics(bits: NDArray[np.uint8], confidence: NDArray[np.float64]) -> str | None:
    """Order-1 ordered-statistics decoding (Fossorier and Lin 1995) of the binary image of
    the Reed-Solomon code, each candidate checked by its CRC and :data:`_OSD_MOST_WRONG`."""
    if confidence.shape != (PAYLOAD_BITS,) or not np.all(np.isfinite(confidence)):
        return None
    order = np.argsort(-np.abs(confidence), kind="stable")
    basis = _generator()[:, order]  # a copy, reduced in place
    pivots: list[int] = []
    for col in range(PAYLOAD_BITS):
        row = len(pivots)
        if row == _MESSAGE_BITS:
            break
        below = np.flatnonzero(basis[row:, col])
        if below.size == 0:
            continue
        if below[0]:
            basis[[row, row + below[0]]] = basis[[row + below[0], row]]
        above = np.flatnonzero(basis[:, col])
        basis[above[above != row]] ^= basis[row]
        pivots.append(col)
    read = bits[order]
    first = (read[pivots].astype(np.int64) @ basis % 2).astype(np.uint8)
    candidates = np.vstack([first, first ^ basis])  # and each basis bit flipped
    wrong = np.count_nonzero(candidates != read, axis=1)
    codes = np.empty_like(candidates)
    codes[:, order] = candidates
    messages = np.packbits(codes[:, :_MESSAGE_BITS], axis=1)
    best: tuple[int, str] | None = None
    for k in np.flatnonzero(wrong <= _OSD_MOST_WRONG):
        message = messages[k].tobytes()
        ident, crc = message[:ID_BYTES], message[ID_BYTES:]
        if zlib.crc32(ident).to_bytes(_CRC_BYTES, "big") == crc and (
            best is None or wrong[k] < best[0]
        ):
            best = (int(wrong[k]), ident.hex())
    return None if best is None else best[1]
