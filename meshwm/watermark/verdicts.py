"""One mesh's verdict for :func:`meshwm.watermark.assets.verify_asset`, and why it is absent.

A verdict explains what it finds: a mark sought in a mesh that carries an id (and the reverse)
is reported as such, not just as "absent".
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.detect import decide, is_detected, mark_p_value
from meshwm.message.mark import default_mark
from meshwm.message.payload import format_id, id_text, parse_id
from meshwm.watermark.extract import Decoder
from meshwm.watermark.pieces import Pieces

__all__ = ["verify_read"]

#: Why a verdict's p-value is 1: every image read every bit at zero confidence.
_NOTHING_READ = "no image of this mesh read a bit of it (no slot, or reads at chance)"


def _logo_reads(decoder: Decoder | Pieces, key: str | bytes, fpr: float) -> bool:
    logo = default_mark(32)
    found = decoder.extract(key=key, mark_size=32, expected=logo)
    return decide(found.report, fpr=fpr).detected


def _id_note(found: str | None, wanted: bytes | None, asked: str | None) -> str | None:
    """Why an id verdict is absent, when the mesh says more than "nothing here"."""
    if found is None:
        return None
    shown = format_id(found)
    if wanted is not None and asked is not None and not asked.lower().startswith("0x"):
        try:
            as_hex = parse_id("0x" + asked)
        except ValueError:
            as_hex = None
        if as_hex is not None and as_hex.hex() == found:
            return (
                f"this mesh carries the id {shown}; an id without 0x is text: did you mean "
                f"--id 0x{asked}?"
            )
    return f"this mesh carries another id: {shown}"


def verify_read(
    decoder: Decoder | Pieces,
    row: dict[str, Any],
    *,
    key: str | bytes,
    ident: bytes | None,
    ident_text: str | None,
    fpr: float,
    expected: NDArray | None,
) -> None:
    """:func:`~meshwm.watermark.assets.verify_asset`'s verdict on one decoder, into ``row``:
    the id ``ident`` (any id when None) when ``expected`` is None, else the mark ``expected``."""
    r: Mapping[str, Any] = {}
    if expected is None:
        got = decoder.extract_id(key=key, expected=ident)
        r = got.report
        if r.get("piece"):
            row["piece"] = r["piece"]
        row.update(id=got.id, id_text=id_text(got.id) if got.id else None, bits=r["bits"])
        if ident is not None:
            verdict = decide(r, fpr=fpr, found_id=got.id, expected_id=ident.hex())
            row.update(p_value=r["p_value"], ber=r["ber"])
            row.update(hypotheses=verdict.hypotheses, threshold=verdict.threshold)
            row["detected"] = verdict.detected
        else:
            row["detected"] = got.id is not None
            row["hypotheses"] = r["hypotheses"]
        if not row["detected"]:
            note = _id_note(got.id, ident, ident_text)
            if note is None and _logo_reads(decoder, key, fpr):
                note = "this mesh carries the bundled logo, not an id: verify without --id"
            if note:
                row["note"] = note
    else:
        # An id first: its CRC settles at the first image that decodes, where a mark read
        # from an id-marked mesh is never clean and would try every image the reader has.
        got = decoder.extract_id(key=key)
        if got.id is not None:
            row.update(id=got.id, id_text=id_text(got.id))
            row["note"] = (
                f"this mesh carries an id, not a mark: {format_id(got.id)}; verify with "
                "--id or --any-id"
            )
            return
        found = decoder.extract(key=key, mark_size=expected.shape[0], expected=expected)
        r = found.report
        if r.get("piece"):
            row["piece"] = r["piece"]
        verdict = decide(r, fpr=fpr)
        row.update(
            detected=verdict.detected,
            p_value=r["p_value"],
            ber=r["ber"],
            correlation=r["correlation"],
            bits=r["bits"],
            hypotheses=verdict.hypotheses,
            threshold=verdict.threshold,
        )
        if not verdict.detected:
            note = _too_little_ink(expected, fpr=fpr, hypotheses=verdict.hypotheses)
            if note:
                row["note"] = note
    if not row["detected"] and r.get("bits_read") == 0 and "note" not in row:
        row["note"] = _NOTHING_READ


def _too_little_ink(mark: NDArray, *, fpr: float, hypotheses: int) -> str | None:
    """Why a mark can never verify, if it cannot: so little ink (or paper) that even a read
    of every bit is what another drawing with as many dots gives by chance
    (:func:`meshwm.detect.mark_p_value`)."""
    bits = mark.ravel()
    best = mark_p_value(bits, bits, np.ones(bits.size))
    if is_detected(best, fpr=fpr, hypotheses=hypotheses):
        return None
    ink = int(bits.sum())
    return (
        f"a mark with {ink} of its {bits.size} pixels inked cannot be told from other drawings "
        f"even read whole (p {best:.3g} at best): it needs more ink and paper both"
    )
