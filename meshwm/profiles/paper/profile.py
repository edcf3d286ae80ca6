"""The paper's scheme as a :class:`meshwm.profiles.base.Profile`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.profiles.base import Decoded, Embedding
from meshwm.profiles.paper.options import PaperOptions
from meshwm.profiles.paper.scheme import embed_gim_paper, extract_gim_paper
from meshwm.readers.base import SampledImage
from meshwm.signal.fill import fill_missing

__all__ = ["PROFILE", "PaperProfile"]


class PaperProfile:
    """Tamane & Deshmukh's scheme, made exact (:mod:`meshwm.profiles.paper`)."""

    name = "paper"
    options_type = PaperOptions
    #: The most hypotheses :meth:`decode` takes on one image (it searches nothing).
    max_hypotheses = 1

    def embed(
        self,
        gim: NDArray[np.float64],
        bits: NDArray[np.uint8],
        *,
        key: str | bytes,
        options: PaperOptions | None = None,
    ) -> Embedding:
        """Embed ``bits`` (:func:`meshwm.profiles.paper.scheme.embed_gim_paper`)."""
        return embed_gim_paper(gim, bits, key=key, options=options)

    def prepare(
        self, image: SampledImage, *, options: PaperOptions | None = None
    ) -> tuple[NDArray[np.float64], PaperOptions]:
        """The received image with lost samples filled, and the options."""
        return fill_missing(image.samples)[0], options or PaperOptions()

    def decode(
        self, prepared: Any, n_bits: int, *, key: str | bytes, thorough: bool = True
    ) -> Decoded:
        """Soft bits (:func:`meshwm.profiles.paper.scheme.extract_gim_paper`); it has no
        candidates, so ``thorough`` changes nothing."""
        gim, options = prepared
        return extract_gim_paper(gim, n_bits, key=key, options=options)


#: The registered instance.
PROFILE = PaperProfile()
