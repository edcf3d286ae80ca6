"""The robust decoder's candidates: the image as received, despiked, with smoothing undone.

Smoothing shrinks the mark's small atoms more than the host's large shapes, which no gain can
fix; impulse noise corrupts a few coefficients badly.  When the image as received decodes with
a mean |confidence| under :data:`UNSMOOTH_BELOW`, the decoder first tries it with impulse
spikes dropped (:func:`meshwm.signal.fill.find_spikes`), then, if the best is still weak, the
reader's images with k steps of uniform Laplacian smoothing undone
(:attr:`meshwm.readers.base.SampledImage.smoothing_undone`), and keeps the candidate that
decodes with the highest mean |confidence|.  Each candidate tried is one more hypothesis for
the false-positive correction (``report["hypotheses"]``).
"""

from __future__ import annotations

import numpy as np

from meshwm.profiles.robust.decode import (
    GAINS_TRIED,
    PreparedGim,
    decode_robust,
    prepare_gim_robust,
)
from meshwm.profiles.robust.options import RobustOptions
from meshwm.profiles.robust.slots import RobustResult
from meshwm.readers.base import SampledImage
from meshwm.signal.fill import find_spikes

__all__ = ["MAX_HYPOTHESES", "UNSMOOTH_BELOW", "Candidates"]

#: Below this mean |confidence| of the image as received the other candidates are tried (an
#: unattacked mesh reads about 0.86: distortion compensation leaves up to 0.15 of a step of
#: self-noise).
UNSMOOTH_BELOW = 0.75
#: The most hypotheses one image can take: every gain on the image as received, despiked and
#: with each of the readers' smoothing steps undone (12 uniform,
#: :data:`meshwm.readers.connectivity.UNSMOOTH_STEPS`, and 5 × 2 cotangent,
#: :data:`meshwm.mesh.unsmooth.COTANGENT_STEPS` × ``COTANGENT_ITERATIONS``).
MAX_HYPOTHESES = GAINS_TRIED * (2 + 12 + 10)


def _strength(res: RobustResult) -> float:
    assert res.confidence is not None  # decode_robust always sets it
    return float(np.mean(np.abs(res.confidence)))


class Candidates:
    """A received image, analysed once and decoded with any number of keys.

    Each candidate is prepared (:func:`meshwm.profiles.robust.decode.prepare_gim_robust`) the
    first time it is needed and kept, so decoding with many keys costs one gain search per
    candidate and key.

    Parameters
    ----------
    image : SampledImage
        What a reader re-derived from the received mesh.
    options : RobustOptions, optional
        As used for embedding (only ``tangential_step`` matters: the gain search's nominal
        step).
    """

    def __init__(self, image: SampledImage, *, options: RobustOptions | None = None) -> None:
        self._image = image
        self._options = options or RobustOptions()
        self._plain: PreparedGim | None = None
        self._despiked: tuple[PreparedGim, float] | None = None
        self._despiked_done = False
        self._unsmoothed: list[tuple[int | str, PreparedGim]] | None = None

    def _prepare(self, samples: np.ndarray) -> PreparedGim:
        return prepare_gim_robust(samples, options=self._options)

    def plain(self) -> PreparedGim:
        """The image as received."""
        if self._plain is None:
            self._plain = self._prepare(self._image.samples)
        return self._plain

    def despiked(self) -> tuple[PreparedGim, float] | None:
        """Spikes dropped and refilled, and their fraction; None if there are none."""
        if not self._despiked_done:
            self._despiked_done = True
            gim = self._image.samples.copy()
            spikes = find_spikes(gim)
            if spikes.any():
                gim[spikes] = np.nan
                self._despiked = (self._prepare(gim), float(spikes.mean()))
        return self._despiked

    def unsmoothed(self) -> list[tuple[int | str, PreparedGim]]:
        """The reader's images with k smoothing steps undone, prepared, with k."""
        if self._unsmoothed is None:
            undo = self._image.smoothing_undone
            found = undo() if undo is not None else []
            self._unsmoothed = [(k, self._prepare(samples)) for k, samples in found]
        return self._unsmoothed

    def decode(self, n_bits: int, *, key: str | bytes, thorough: bool = True) -> RobustResult:
        """Bits with ``key`` from the best candidate; ``hypotheses`` = gains × candidates.

        ``thorough=False``: the image as received, and despiked if that reads weakly; the
        smoothing undone only with True.
        """
        best = decode_robust(self.plain(), n_bits, key=key)
        best_k: int | str = 0
        tried = 1
        despiked = 0.0
        if _strength(best) < UNSMOOTH_BELOW:
            found = self.despiked()
            if found is not None:
                tried += 1
                res = decode_robust(found[0], n_bits, key=key)
                if _strength(res) > _strength(best):
                    best, despiked = res, found[1]
        if thorough and _strength(best) < UNSMOOTH_BELOW:  # despiking did not make it clean
            for k, prepared in self.unsmoothed():
                tried += 1
                res = decode_robust(prepared, n_bits, key=key)
                if _strength(res) > _strength(best):
                    best, best_k = res, k
        report = {
            **best.report,
            "unsmoothed": best_k,
            "despiked": despiked,
            "hypotheses": best.report["gains_tried"] * tried,
        }
        return RobustResult(None, best.bits, best.confidence, report)
