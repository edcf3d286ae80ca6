"""Blind extraction on meshes: a reader re-derives the geometry image, the profile decodes it."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import DEFAULT_MAX_FACES
from meshwm.detect import DEFAULT_FPR, Verdict, decide, mark_p_value, read_p_value
from meshwm.message.keying import key_bytes
from meshwm.message.mark import neighbour_correlation
from meshwm.message.payload import PAYLOAD_BITS, decode_id, encode_id
from meshwm.message.scramble import arnold_scramble, arnold_unscramble
from meshwm.metrics import bit_error_rate, correlation2
from meshwm.params import WatermarkParams
from meshwm.profiles import get_decoder, get_profile
from meshwm.profiles.base import Decoded, ImageDecoder
from meshwm.profiles.robust.search import UNSMOOTH_BELOW
from meshwm.readers import read_all
from meshwm.readers.base import SampledImage
from meshwm.watermark.checks import check_gim, check_mark

__all__ = ["Decoder", "Extracted", "ExtractedId", "extract", "extract_gim", "extract_id", "verify"]


class Extracted(NamedTuple):
    """Result of :func:`extract` or :func:`extract_gim`.

    Attributes
    ----------
    mark : (k, k) uint8 ndarray
        The extracted mark, unscrambled (0/1).
    bits : (k*k,) uint8 ndarray
        The bits as carried (scrambled order).
    confidence : (k*k,) float64 ndarray
        Each bit's soft vote over its weight: near +1 or -1 for a clean read, near 0 for
        noise.
    report : dict
        ``n``, ``carriers``, ``hypotheses``, ``seconds`` and, when an expected mark was given,
        ``ber``, ``correlation``, ``p_value`` and ``bits``.
    """

    mark: NDArray[np.uint8]
    bits: NDArray[np.uint8]
    confidence: NDArray[np.float64]
    report: dict[str, Any]


def _as_mark(bits: NDArray[np.uint8], arnold_iterations: int) -> NDArray[np.uint8]:
    """Bits as a square mark, unscrambled, when their count is a square; else one row."""
    side = round(np.sqrt(len(bits)))
    if side * side == len(bits):
        mark = arnold_unscramble(bits.reshape(side, side), iterations=arnold_iterations)
    else:
        mark = bits.reshape(1, -1)
    return mark.astype(np.uint8)


def extract_gim(
    gim: NDArray, n_bits: int, *, key: str | bytes, params: WatermarkParams | None = None
) -> Extracted:
    """Read ``n_bits`` bits from a geometry image with the profile ``params.profile``, blind.

    Parameters
    ----------
    gim : (N, N, 3) float64 ndarray
        The received geometry image, finite (for a mesh that lost samples: :func:`extract`).
    n_bits : int
        Payload length (for a mark: its side squared).
    key : str or bytes
        The secret key.
    params : WatermarkParams, optional
        As used for embedding.

    Returns
    -------
    Extracted
        ``mark`` is the bits as a square image when ``n_bits`` is a square (unscrambled with
        ``params.arnold_iterations``), else a single row.
    """
    params = params or WatermarkParams()
    gim = check_gim(gim, params)
    if isinstance(n_bits, bool) or not isinstance(n_bits, (int, np.integer)) or n_bits < 1:
        raise ValueError(f"n_bits must be a positive integer, got {n_bits!r}")
    profile = get_profile(params.profile)
    prepared = profile.prepare(SampledImage(gim, 1, "given"), options=params.options)
    found = profile.decode(prepared, int(n_bits), key=key)
    mark = _as_mark(found.bits, params.arnold_iterations)
    return Extracted(mark, found.bits, found.confidence, found.report)


#: How many images besides the readers' primary ones, the strongest as received, are decoded
#: again with every candidate (the robust profile's smoothing undone).  A smoothed mark reads
#: weakly as received, and not always more strongly than another start's image (spot after
#: MeshLab's Laplacian: 0.345 through its own map, 0.38 through another), so the primary images
#: are always among them (each connectivity's canonical start: spot with its seams split and
#: then MeshLab's Laplacian reads through the zipped mesh's, 0.363 as received where six other
#: images read 0.36-0.385, and decodes only with the smoothing undone).
THOROUGH_IMAGES = 3
#: An id's code is accepted by :meth:`Decoder.reads` with this fraction of its bits wrong, if
#: the id still decodes (Reed-Solomon corrects them).
_ID_SLACK = 0.02
#: A mark (a logo: an image, judged by how many of its bits agree) is accepted with this
#: fraction of its bits wrong; the embedder reports how many.  A 32×32 logo with 20 wrong
#: pixels is still the logo, detected at a p-value under 1e-250; exact, it was refused on
#: plane_holes for one wrong bit of 1,024 and on kitten and human_neutral for 1.4 and 1.1 %.
_MARK_SLACK = 0.02
#: A mark's image is picked as a drawing (:meth:`Decoder.decode`) when its extracted mark's
#: neighbour correlation is this many standard deviations of noise's above 0: a chance
#: correlation of noise this strong comes about once in 3.5 million reads.
_DRAWN_SIGMAS = 5.0


def _strength(found: Decoded) -> float:
    """How strongly an image reads: its mean |confidence|."""
    return float(np.mean(np.abs(found.confidence)))


def _clean(found: Decoded) -> bool:
    """A read no other image could beat: every vote as strong as an unattacked read's."""
    return _strength(found) >= UNSMOOTH_BELOW


class _Try(NamedTuple):
    """One image a reader offered (the ``k``-th), decoded."""

    strength: float
    image: SampledImage
    found: Decoded
    k: int


class Decoder:
    """A received mesh, read once, to decode with one key or many.

    Reading the geometry image (:func:`meshwm.readers.read_all`) and the key-independent
    analysis (the profile's ``prepare``) are done once; each :meth:`extract` /
    :meth:`extract_id` then only runs the keyed decoder.  :func:`extract` and
    :func:`extract_id` are ``Decoder(...).extract(...)`` and ``Decoder(...).extract_id(...)``.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose).
    params : WatermarkParams, optional
        As used for embedding (``size`` is ignored in favour of the N found).
    max_faces : int, optional
        Refuse larger inputs.
    hints : mapping, optional
        Per-reader keyword arguments that change a reader's speed, never what it reads
        (:func:`meshwm.readers.read_all`).
    readers : sequence of str, optional
        Only these readers (names of :data:`meshwm.readers.READERS`); default all.
    mirror : bool, optional
        Whether the readers of :data:`meshwm.readers.MIRRORED` also read the mesh's mirror
        image (default; a change of handedness mirrors a mesh).

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No reader found a geometry image (not marked by meshwm, or remeshed).

    Examples
    --------
    >>> from meshwm.gim.to_mesh import geometry_image_to_mesh
    >>> n = 64
    >>> i, j = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    >>> gim = np.stack([i, j, 0.1 * np.sin(6 * i) * np.cos(5 * j)], axis=-1)
    >>> decoder = Decoder(*geometry_image_to_mesh(gim))
    >>> decoder.image.n, decoder.extract(key="any", mark_size=8).report["hypotheses"] > 1
    (64, True)
    """

    def __init__(
        self,
        vertices: NDArray,
        faces: NDArray,
        *,
        params: WatermarkParams | None = None,
        max_faces: int = DEFAULT_MAX_FACES,
        hints: Mapping[str, Mapping[str, Any]] | None = None,
        readers: Sequence[str] | None = None,
        mirror: bool = True,
    ) -> None:
        images = read_all(
            vertices, faces, max_faces=max_faces, hints=hints, readers=readers, mirror=mirror
        )
        params = params or WatermarkParams()
        if images[0].n != params.size:
            params = dataclasses.replace(params, size=images[0].n)
        #: Every image the readers re-derive (:class:`meshwm.readers.base.SampledImage`), made
        #: as the decoder gets to them; the decoder tries each (a reader that samples at several
        #: sizes or starts offers several).
        self.images = images
        #: The first of them.
        self.image = images[0]
        #: The parameters used (``size`` is the first N found).
        self.params = params
        self._prepared: dict[int, Any] = {}
        self._hypotheses: int | None = None

    def _decoder(self, scheme: str | None) -> ImageDecoder:
        return get_decoder(scheme, self.params.profile)

    def _prepare(self, k: int) -> Any:
        if k not in self._prepared:
            image = self.images[k]
            decoder = self._decoder(image.scheme)
            self._prepared[k] = decoder.prepare(image, options=self.params.options)
        return self._prepared[k]

    @property
    def hypotheses(self) -> int:
        """Every hypothesis the decoder can try on this mesh: over all the images the readers
        can offer, each image's count times its decoder's most (candidates × gains).

        The Bonferroni correction divides the false-positive budget by this, whatever was
        actually tried before a read was accepted (:meth:`meshwm.readers.base.ChainedImages.bound`):
        the count depends on the mesh alone.
        """
        if self._hypotheses is None:
            self._hypotheses = self.images.bound(lambda s: self._decoder(s).max_hypotheses)
        return self._hypotheses

    def _decode_all(
        self, n_bits: int, *, key: str | bytes, enough: Callable[[Decoded], bool] | None = None
    ) -> tuple[list[_Try], int]:
        """The images decoded, strongest first, and :attr:`hypotheses`.

        First every image as received (the robust profile: as received and despiked), in the
        readers' order; then again with every candidate their decoder has (the robust profile:
        smoothing undone), the readers' primary images (each connectivity's canonical cut
        start) and the :data:`THOROUGH_IMAGES` strongest others.  An image a reader offers
        twice (the same object) is decoded once.  With ``enough``, decoding stops at the first
        read it accepts.
        """
        tried: list[_Try] = []
        # A reader may offer one image twice (the surface reader's starts that give an image
        # another start gave, on the mesh or its mirror image): decoded once (as the ``k`` of
        # its first place), its decode stands for both, and it is read again with every
        # candidate once at most.
        first_of: dict[int, int] = {}
        for k, image in enumerate(self.images):
            j = first_of.setdefault(id(image), k)
            if j < k:
                tried.append(tried[j])
                continue
            found = self._decoder(image.scheme).decode(
                self._prepare(k), n_bits, key=key, thorough=False
            )
            tried.append(_Try(_strength(found), image, found, k))
            if enough is not None and enough(found):
                return sorted(tried, key=lambda t: -t.strength), self.hypotheses
        once = [k for k, t in enumerate(tried) if t.k == k]  # not an image offered again
        strongest = sorted(once, key=lambda i: -tried[i].strength)
        primary = [k for k in once if tried[k].image.primary]
        again = primary + [k for k in strongest if k not in primary][:THOROUGH_IMAGES]
        for k in again:
            image = tried[k].image
            found = self._decoder(image.scheme).decode(
                self._prepare(k), n_bits, key=key, thorough=True
            )
            strength = _strength(found)
            if strength > tried[k].strength:
                tried[k] = _Try(strength, image, found, k)
            if enough is not None and enough(found):
                break
        return sorted(tried, key=lambda t: -t.strength), self.hypotheses

    @staticmethod
    def _result(chosen: _Try, hypotheses: int) -> tuple[NDArray, NDArray, dict[str, Any]]:
        found, image = chosen.found, chosen.image
        report = {**found.report, "n": image.n, "reader": image.reader, "hypotheses": hypotheses}
        return found.bits, found.confidence, report

    def decode(
        self, n_bits: int, *, key: str | bytes
    ) -> tuple[NDArray[np.uint8], NDArray[np.float64], dict[str, Any]]:
        """``n_bits`` raw bits, their confidence, and a report with ``hypotheses``.

        Every image the reader offered is decoded and, among those that read something (a
        bit of nonzero confidence), the one whose mark reads most like a drawing kept
        (:meth:`_drawn`), else, when none does, the one that reads most strongly above noise
        (:meth:`_above_noise`); its ``n`` and ``reader`` are reported, and ``chosen_by``
        (``"drawing"`` or ``"strength"``);
        ``hypotheses`` is the sum over the images of the reader's count times the profile's
        (gains, candidates).
        """
        tried, hypotheses = self._decode_all(n_bits, key=key, enough=_clean)
        # An image that read nothing (every confidence 0: no slot for these bits, or a read at
        # chance) is no candidate while another read something; its bits are 0s, not a read.
        tried = [t for t in tried if t.strength > 0] or tried  # strength: mean |confidence|
        chosen, chosen_by = self._drawn(tried), "drawing"
        if chosen is None:
            # A key no mark was made with: what each image reads of noise.
            noise = key_bytes(key, "a read of noise", 32)
            chosen = max(tried, key=lambda t: self._above_noise(t, noise))
            chosen_by = "strength"
        bits, confidence, report = self._result(chosen, hypotheses)
        return bits, confidence, {**report, "chosen_by": chosen_by}

    def _drawn(self, tried: Sequence[_Try]) -> _Try | None:
        """The image whose mark reads most like a drawing, if any reads clearly so.

        A logo's strokes make neighbouring pixels agree, noise's do not
        (:func:`meshwm.message.mark.neighbour_correlation`), and a read keeps
        ``(1 - 2 e)**2`` of the logo's correlation at a bit error rate ``e``: among the
        images whose marks correlate at :data:`_DRAWN_SIGMAS` or more, the one that
        correlates most has the fewest wrong bits.  Strength tells that less well: the
        images read with every candidate read noise strongly too (fandisk's logo after 9-bit
        quantisation: its own image 0.123 above noise with 9 % of the bits wrong, its
        mirror image's 0.129 with half), and the radial carrier's reads are stronger than
        the surface's with more bits wrong (kitten after 16-bit quantisation: 6.0 % against
        1.5 %).  A mark with no drawing in it (random bits), or read too weakly to show
        one, is picked by strength (:meth:`_above_noise`).  Blind: the expected mark plays
        no part.
        """
        best: _Try | None = None
        most = 0.0
        for t in tried:
            mark = _as_mark(t.found.bits, self.params.arnold_iterations)
            if mark.shape[0] == 1:  # not a square: no drawing to look for
                return None
            r, pairs = neighbour_correlation(mark)
            if r * np.sqrt(pairs) >= _DRAWN_SIGMAS and r > most:
                best, most = t, r
        return best

    def _above_noise(self, tried: _Try, noise: bytes) -> float:
        """How strongly an image reads a mark: where its mean |confidence| lies between what
        the same image reads with a key no mark was made with (0) and a perfect read (1).

        A mark (a logo) has no code to tell its own image, and raw strengths favour the
        images with fewer slots a bit: a 32×32 logo's images at N = 128 (1.7 slots a bit)
        read noise at 0.58, and outranked kitten's marked image at N = 256 (0.49, 1.4 % of the
        bits wrong; noise there reads 0.31), so that after 16-bit quantisation or 0.1 % noise
        the extracted logo was noise.  Scaled to a perfect read, not only shifted by noise's,
        so that it compares with the radial reader's (whose reads of noise score about 0):
        shifted only, plane_holes' logo after 16-bit quantisation was read through the
        radial carrier at 0.43 (13.8 % of the bits wrong) rather than the surface's at 0.38
        (0.2 %).  (An id is chosen by its code, which decodes on its own image only, and
        which images are read again with the smoothing undone stays with the raw strength:
        ranked otherwise, camelhead lost its id after Laplacian ×10.)
        """
        n_bits = len(tried.found.bits)
        read = self._decoder(tried.image.scheme).decode(
            self._prepare(tried.k), n_bits, key=noise, thorough=False
        )
        chance = min(_strength(read), 0.99)
        return (tried.strength - chance) / (1.0 - chance)

    def reads(self, bits: NDArray[np.uint8], *, key: str | bytes) -> tuple[bool, float]:
        """Whether some image decodes to ``bits``: exactly, or with at most 2 % of them wrong
        (an id's code: if it still decodes to that id; a mark: as it is), and the least bit
        error rate found.

        Decoding stops at the first image that reads the bits exactly (or an id's code that
        decodes to the id): the embedder's check of its output.
        """
        bits = np.asarray(bits, dtype=np.uint8)
        ident = decode_id(bits) if len(bits) == PAYLOAD_BITS else None

        def accept(found: Decoded) -> bool:
            wrong = float(np.mean(found.bits != bits))
            if wrong == 0:
                return True
            return (
                ident is not None
                and wrong <= _ID_SLACK
                and decode_id(found.bits, found.confidence) == ident
            )

        # A mark read with a few bits wrong does not end the search: another image may read
        # it whole, and the least error found is what the embedder reports.
        tried, _ = self._decode_all(len(bits), key=key, enough=accept)
        least = min(float(np.mean(t.found.bits != bits)) for t in tried)
        ok = any(accept(t.found) for t in tried) or (ident is None and least <= _MARK_SLACK)
        return ok, least

    def extract(
        self, *, key: str | bytes, mark_size: int = 32, expected: NDArray | None = None
    ) -> Extracted:
        """The mark, as :func:`extract` describes."""
        t0 = time.perf_counter()
        params = self.params
        n_bits = int(mark_size) ** 2
        bits, confidence, found_report = self.decode(n_bits, key=key)
        mark = _as_mark(bits, params.arnold_iterations)
        report = {"profile": params.profile, **found_report, "mark_size": int(mark_size)}
        if expected is not None:
            exp = check_mark(expected)
            if exp.shape != mark.shape:
                raise ValueError(f"expected mark is {exp.shape}, extracted {mark.shape}")
            exp_bits = arnold_scramble(exp, iterations=params.arnold_iterations).ravel()
            report["bits"] = n_bits
            report["ber"] = bit_error_rate(exp_bits, bits)
            report["correlation"] = correlation2(exp, mark)
            report["p_value"] = mark_p_value(exp_bits, bits, confidence)
            report["bits_read"] = int(np.count_nonzero(confidence))
        report["seconds"] = time.perf_counter() - t0
        return Extracted(mark, bits, confidence, report)

    def extract_id(self, *, key: str | bytes, expected: bytes | None = None) -> ExtractedId:
        """The id, as :func:`extract_id` describes."""
        t0 = time.perf_counter()
        # Each read's id, decoded once (the read is kept alive with it, so its id() is its own).
        decoded: dict[int, tuple[Decoded, str | None]] = {}

        def read_id(found: Decoded) -> str | None:
            if id(found) not in decoded:
                decoded[id(found)] = (found, decode_id(found.bits, found.confidence))
            return decoded[id(found)][1]

        tried, hypotheses = self._decode_all(
            PAYLOAD_BITS, key=key, enough=lambda found: read_id(found) is not None
        )
        # The strongest image whose code bits decode to a valid id (CRC-32 checked), else the
        # strongest: every image is a hypothesis counted for the false-positive rate either way.
        chosen = ([t for t in tried if read_id(t.found) is not None] or tried)[0]
        bits, confidence, found = self._result(chosen, hypotheses)
        ident = read_id(chosen.found)
        report = {"profile": self.params.profile, **found, "id": ident, "bits": PAYLOAD_BITS}
        if expected is not None:
            code = encode_id(expected)
            report["ber"] = bit_error_rate(code, bits)
            report["p_value"] = read_p_value(code, bits, confidence)
            report["bits_read"] = int(np.count_nonzero(confidence))
        report["seconds"] = time.perf_counter() - t0
        return ExtractedId(ident, bits, confidence, report)


class ExtractedId(NamedTuple):
    """Output of :func:`extract_id`: ``id`` is 16 hex digits, or None if none decodes."""

    id: str | None
    bits: NDArray[np.uint8]
    confidence: NDArray[np.float64]
    report: dict[str, Any]


def extract_id(
    vertices: NDArray,
    faces: NDArray,
    *,
    key: str | bytes,
    expected: bytes | None = None,
    params: WatermarkParams | None = None,
    max_faces: int = DEFAULT_MAX_FACES,
) -> ExtractedId:
    """Blind extraction of an id embedded with ``embed(..., ident=...)``.

    The 256 code bits are decoded (Reed-Solomon with erasures from the per-bit confidence,
    then CRC-32, :func:`meshwm.message.payload.decode_id`); an id is reported only when its CRC
    matches, so a corrupted id is ``None``, never a wrong one.  With ``expected``, the report
    also has ``ber`` and ``p_value`` of the code bits against that id's code (binomial tail).

    Raises
    ------
    GridError
        No meshwm grid in the connectivity.
    """
    t0 = time.perf_counter()
    decoder = Decoder(vertices, faces, params=params, max_faces=max_faces)
    found = decoder.extract_id(key=key, expected=expected)
    found.report["seconds"] = time.perf_counter() - t0
    return found


def extract(
    vertices: NDArray,
    faces: NDArray,
    *,
    key: str | bytes,
    mark_size: int = 32,
    expected: NDArray | None = None,
    params: WatermarkParams | None = None,
    max_faces: int = DEFAULT_MAX_FACES,
) -> Extracted:
    """Blind extraction from a received mesh: only its geometry, connectivity and the key.

    A reader (:func:`meshwm.readers.read_received`) re-derives the geometry image from the
    received mesh alone (its size N, which vertex is which sample, its orientation);
    ``params.size`` is ignored in favour of the N found.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh (any vertex and face order, any pose).
    key : str or bytes
        The secret key.
    mark_size : int, optional
        Side of the square mark (default 32).
    expected : (k, k) array of 0/1, optional
        The original mark: adds ``ber``, ``correlation`` (MATLAB corr2), ``bits`` and
        ``p_value`` (binomial tail of the bit agreement) to the report.
    params : WatermarkParams, optional
        As used for embedding.
    max_faces : int, optional
        Refuse larger inputs.

    Returns
    -------
    Extracted

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No meshwm grid in the connectivity (not marked by meshwm, or remeshed).
    """
    t0 = time.perf_counter()
    decoder = Decoder(vertices, faces, params=params, max_faces=max_faces)
    found = decoder.extract(key=key, mark_size=mark_size, expected=expected)
    found.report["seconds"] = time.perf_counter() - t0
    return found


def verify(
    vertices: NDArray,
    faces: NDArray,
    *,
    key: str | bytes,
    mark: NDArray | None = None,
    ident: bytes | None = None,
    fpr: float = DEFAULT_FPR,
    params: WatermarkParams | None = None,
    max_faces: int = DEFAULT_MAX_FACES,
) -> Verdict:
    """Is the mark (or the id) there?  Blind extraction, then :func:`meshwm.detect.decide`.

    Parameters
    ----------
    vertices, faces : array_like
        The received mesh.
    key : str or bytes
        The secret key.
    mark : (k, k) array of 0/1, optional
        The expected mark (default: the bundled logo, unless ``ident`` is given).
    ident : bytes, optional
        The expected 64-bit id (8 bytes, :func:`meshwm.message.payload.parse_id`); detection
        also needs the id read back to be this one.
    fpr : float, optional
        The false-positive rate, divided by the number of hypotheses tried (Bonferroni).
    params : WatermarkParams, optional
        As used for embedding.
    max_faces : int, optional
        Refuse larger inputs.

    Returns
    -------
    meshwm.detect.Verdict

    Raises
    ------
    MeshError
        Unusable mesh arrays.
    GridError
        No meshwm grid in the connectivity.
    """
    if mark is not None and ident is not None:
        raise ValueError("give the expected mark or the expected id, not both")
    if ident is not None:
        got = extract_id(
            vertices, faces, key=key, expected=ident, params=params, max_faces=max_faces
        )
        return decide(got.report, fpr=fpr, found_id=got.id, expected_id=ident.hex())
    expected = check_mark(mark)  # None: the bundled logo
    found = extract(
        vertices,
        faces,
        key=key,
        mark_size=expected.shape[0],
        expected=expected,
        params=params,
        max_faces=max_faces,
    )
    return decide(found.report, fpr=fpr)
