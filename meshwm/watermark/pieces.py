"""A mesh of several pieces: marked piece by piece, read whole and then piece by piece."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import CapacityError, GridError, MeshError
from meshwm.mesh.manifold import face_components, large_pieces
from meshwm.params import WatermarkParams
from meshwm.watermark.embed import Embedded, embed
from meshwm.watermark.extract import Decoder, Extracted, ExtractedId

__all__ = ["Pieces", "embed_by_piece"]

#: The errors that leave a piece unread without ending the others.
_PIECE_ERRORS = (CapacityError, GridError, MeshError, np.linalg.LinAlgError)


class Pieces:
    """A mesh read whole and, when it joins several pieces each big enough for the payload,
    each of those pieces alone: a marked asset joined to other objects in one mesh (a scene
    exported as one object, a kit of props joined) is still read.

    The whole mesh's readers map its piece of largest area and read the radial carrier over every
    piece together, so a marked mesh joined to a larger object, or to any object after an
    edit only the radial carrier survives, reads only alone.  Each piece alone is one more
    :class:`~meshwm.watermark.extract.Decoder`, and every decoder's hypotheses count in every
    verdict (Bonferroni over all of them, whichever reads), so the false-positive rate holds
    whatever piece is read.  Decoding stops at the first reading whose id decodes (the
    expected one, when one is expected); a mark is read in every piece.

    Parameters
    ----------
    whole : Decoder or None
        The whole mesh's (None: no reader reads the whole mesh).
    pieces : list of (vertices, faces)
        The pieces big enough for the payload, the largest first (two or more).
    make : callable
        ``make(vertices, faces)``: a piece's decoder.
    """

    def __init__(
        self,
        whole: Decoder | None,
        pieces: list[tuple[NDArray[np.float64], NDArray[np.int64]]],
        make: Callable[[NDArray[np.float64], NDArray[np.int64]], Decoder],
    ) -> None:
        self._decoders: list[tuple[dict[str, int] | None, Decoder]] = []
        if whole is not None:
            self._decoders.append((None, whole))
        for k, (v, f) in enumerate(pieces):
            try:
                decoder = make(v, f)
            except _PIECE_ERRORS:  # no reader can read this piece: nothing to try there
                continue
            where = {"index": k + 1, "of": len(pieces), "vertices": len(v)}
            self._decoders.append((where, decoder))

    def __len__(self) -> int:
        """How many readings (the whole mesh's, if it reads, and each piece's that does)."""
        return len(self._decoders)

    @property
    def hypotheses(self) -> int:
        """Every reading's hypotheses, summed."""
        return sum(decoder.hypotheses for _, decoder in self._decoders)

    def _report(self, report: dict[str, Any], where: dict[str, int] | None) -> dict[str, Any]:
        return {**report, "hypotheses": self.hypotheses, "piece": where}

    def extract_id(self, *, key: str | bytes, expected: bytes | None = None) -> ExtractedId:
        """:meth:`Decoder.extract_id` of the first reading whose id decodes (the expected
        one first), else of the reading closest to ``expected`` (the whole mesh's without
        one); ``hypotheses`` counts every reading's, ``piece`` says which piece read (None:
        the whole mesh)."""
        want = expected.hex() if expected is not None else None
        reads: list[tuple[dict[str, int] | None, ExtractedId]] = []
        for where, decoder in self._decoders:
            got = decoder.extract_id(key=key, expected=expected)
            reads.append((where, got))
            if got.id is not None and (want is None or got.id == want):
                break
        valid = [r for r in reads if r[1].id is not None]
        hits = [r for r in valid if want is None or r[1].id == want]
        if hits or valid:
            where, got = (hits or valid)[0]
        elif expected is not None:
            where, got = min(reads, key=lambda r: float(r[1].report["p_value"]))
        else:
            where, got = reads[0]
        return got._replace(report=self._report(got.report, where))

    def extract(
        self, *, key: str | bytes, mark_size: int = 32, expected: NDArray | None = None
    ) -> Extracted:
        """:meth:`Decoder.extract` of every reading: the one that agrees best with
        ``expected`` (least p-value), else the first taken as a drawing, else the whole
        mesh's; ``hypotheses`` and ``piece`` as for :meth:`extract_id`."""
        reads = [
            (where, decoder.extract(key=key, mark_size=mark_size, expected=expected))
            for where, decoder in self._decoders
        ]
        if expected is not None:
            where, found = min(reads, key=lambda r: float(r[1].report["p_value"]))
        else:
            drawn = [r for r in reads if r[1].report.get("chosen_by") == "drawing"]
            where, found = (drawn or reads)[0]
        return found._replace(report=self._report(found.report, where))


def embed_by_piece(
    vertices: NDArray[np.float64],
    faces: NDArray[np.int64],
    mark: NDArray | None,
    *,
    key: str | bytes,
    ident: bytes | None,
    params: WatermarkParams | None,
    max_faces: int,
    least: int,
) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """One mesh marked: whole (:func:`meshwm.watermark.embed`), or, where it joins two or
    more pieces of at least ``least`` vertices, each of those pieces alone with the same
    payload, so that each carries it wherever it goes (split off, or joined to other objects:
    :class:`Pieces` reads each piece alone); smaller pieces are kept
    as they are.  The report is the largest marked piece's, with ``pieces`` (``marked``,
    ``of``: how many of the big pieces carry the payload, ``smaller``: the pieces too small)
    and ``pieces_unmarked`` (each big piece's reason for not carrying it).

    Raises
    ------
    CapacityError, GridError, MeshError
        The whole mesh's, or the first big piece's when none could be marked.
    """

    def mark_one(v: NDArray[np.float64], f: NDArray[np.int64]) -> Embedded:
        return embed(
            v, f, mark, key=key, ident=ident, params=params, max_faces=max_faces, distances=False
        )

    pieces = large_pieces(vertices, faces, least=least)
    if len(pieces) < 2:
        result = mark_one(vertices, faces)
        return result.vertices, _figures_of(result.report)
    new = np.array(vertices, dtype=np.float64)
    reports, reasons, first = [], [], None
    for number, piece in enumerate(pieces, start=1):
        try:
            result = mark_one(piece.vertices, piece.faces)
        except _PIECE_ERRORS as exc:
            first = first or exc
            reasons.append(f"piece {number} ({len(piece.vertices)} vertices): {exc}")
            continue
        new[piece.used] = result.vertices
        reports.append(result.report)
    if not reports:
        assert first is not None
        raise first
    report = _figures_of(reports[0])
    smaller = int(face_components(len(vertices), faces).max()) + 1 - len(pieces)
    report["pieces"] = {"marked": len(reports), "of": len(pieces), "smaller": smaller}
    if reasons:
        report["pieces_unmarked"] = reasons
    report.pop("components_passed_through", None)  # each piece was marked alone
    return new, report


def _figures_of(report: Mapping[str, Any]) -> dict[str, Any]:
    """An embedding's report as a mesh's row takes it (less what the row says itself)."""
    return {n: v for n, v in report.items() if n not in ("vertices", "faces", "id")}
