"""Tests for :mod:`meshwm.watermark.pieces`: which reading of a mesh of several pieces is
reported, and that every reading counts (fake decoders; the command on a joined kit:
``tests/apps/cli/test_cli_assets.py``)."""

from __future__ import annotations

import numpy as np

from meshwm.errors import GridError
from meshwm.watermark.extract import Extracted, ExtractedId
from meshwm.watermark.pieces import Pieces


class _FakeDecoder:
    """A decoder that reads a fixed id (or none) at a fixed p-value, and counts its reads."""

    def __init__(self, ident: str | None, p_value: float, hypotheses: int) -> None:
        self.ident, self.p_value, self.hypotheses, self.reads = ident, p_value, hypotheses, 0

    def extract_id(self, *, key, expected=None):
        self.reads += 1
        report = {"p_value": self.p_value, "hypotheses": self.hypotheses, "reader": "surface"}
        return ExtractedId(self.ident, np.zeros(256, np.uint8), np.zeros(256), report)

    def extract(self, *, key, mark_size=32, expected=None):
        self.reads += 1
        report = {"p_value": self.p_value, "hypotheses": self.hypotheses, "chosen_by": "strength"}
        bits = np.zeros(mark_size * mark_size, np.uint8)
        return Extracted(bits.reshape(mark_size, -1), bits, np.zeros(bits.size), report)


def _pieces(whole, *readings):
    """:class:`Pieces` over fake decoders: ``readings`` are decoders, or None for a piece no
    reader can read (its ``make`` raises)."""
    made = iter(readings)

    def make(v, f):
        found = next(made)
        if found is None:
            raise GridError("no surface here")
        return found

    pieces = [
        (np.zeros((k + 3, 3)), np.zeros((1, 3), dtype=np.int64)) for k in range(len(readings))
    ]
    return Pieces(whole, pieces, make)


def test_the_expected_id_is_sought_in_every_piece_and_every_reading_counted():
    whole = _FakeDecoder("aa" * 8, 1e-30, 100)  # another id, read whole
    first, second = _FakeDecoder(None, 0.3, 10), _FakeDecoder("0123456789abcdef", 1e-40, 7)
    unread = _FakeDecoder("0123456789abcdef", 1e-50, 5)
    pieces = _pieces(whole, first, None, second, unread)
    assert len(pieces) == 4 and pieces.hypotheses == 100 + 10 + 7 + 5  # the failed piece: none
    got = pieces.extract_id(key="k", expected=bytes.fromhex("0123456789abcdef"))
    assert got.id == "0123456789abcdef" and got.report["hypotheses"] == 122
    assert got.report["piece"] == {"index": 3, "of": 4, "vertices": 5}
    assert unread.reads == 0  # decoding stops at the first reading of the expected id
    # Any id: the whole mesh's, which reads first.
    got = pieces.extract_id(key="k")
    assert got.id == "aa" * 8 and got.report["piece"] is None and first.reads == 1


def test_with_no_id_anywhere_the_reading_closest_to_the_expected_one_is_reported():
    pieces = _pieces(_FakeDecoder(None, 0.5, 3), _FakeDecoder(None, 0.01, 3))
    got = pieces.extract_id(key="k", expected=bytes(8))
    assert got.id is None and got.report["p_value"] == 0.01 and got.report["hypotheses"] == 6
    assert got.report["piece"]["index"] == 1
    assert pieces.extract_id(key="k").report["piece"] is None  # no id sought: the whole's
    mark = pieces.extract(key="k", mark_size=4, expected=np.zeros((4, 4), np.uint8))
    assert mark.report["p_value"] == 0.01 and mark.report["piece"]["index"] == 1


def test_a_mesh_whose_whole_no_reader_reads_is_read_piece_by_piece():
    alone = _FakeDecoder("0123456789abcdef", 1e-40, 7)
    pieces = _pieces(None, _FakeDecoder(None, 0.4, 2), alone)
    got = pieces.extract_id(key="k")
    assert got.id == "0123456789abcdef" and got.report["hypotheses"] == 9
    assert len(_pieces(None, None, None)) == 0  # nothing to read: the caller reports the reason
