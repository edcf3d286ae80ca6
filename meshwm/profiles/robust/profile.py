"""The robust profile as a :class:`meshwm.profiles.base.Profile`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import CapacityError
from meshwm.profiles.base import Decoded, Embedding
from meshwm.profiles.robust.embed import embed_gim_robust
from meshwm.profiles.robust.options import RobustOptions
from meshwm.profiles.robust.search import MAX_HYPOTHESES, Candidates
from meshwm.profiles.robust.slots import _layout
from meshwm.readers.base import SampledImage

__all__ = ["PROFILE", "RobustProfile"]


class RobustProfile:
    """meshwm's default scheme for real pipelines (:mod:`meshwm.profiles.robust`)."""

    name = "robust"
    options_type = RobustOptions
    #: The most hypotheses :meth:`decode` takes on one image.
    max_hypotheses = MAX_HYPOTHESES

    def embed(
        self,
        gim: NDArray[np.float64],
        bits: NDArray[np.uint8],
        *,
        key: str | bytes,
        options: RobustOptions | None = None,
    ) -> Embedding:
        """Embed ``bits`` (:func:`meshwm.profiles.robust.embed.embed_gim_robust`)."""
        res = embed_gim_robust(gim, bits, key=key, options=options)
        assert res.gim is not None  # embedding always returns the marked image
        return Embedding(np.asarray(gim, dtype=np.float64), res.gim, res.report)

    def reinforce(
        self,
        gim: NDArray[np.float64],
        bits: NDArray[np.uint8],
        *,
        key: str | bytes,
        options: RobustOptions,
        weak: NDArray[np.bool_],
    ) -> Embedding:
        """Embed the bits ``weak`` only, at ``options.tangential_step``: the slots of every
        other bit keep their values (:func:`~meshwm.profiles.robust.embed.embed_gim_robust`'s
        ``only``)."""
        if options.tangential_step is None:
            raise ValueError("reinforce needs the embedding's tangential_step")
        res = embed_gim_robust(gim, bits, key=key, options=options, only=weak)
        assert res.gim is not None
        return Embedding(np.asarray(gim, dtype=np.float64), res.gim, res.report)

    def warm(self, size: int, *, key: str | bytes, n_bits: int) -> None:
        """Make (and keep) the keyed slot layout an N = ``size`` image will use: a caller may
        run this beside other work.  A payload the size cannot carry is left for
        :meth:`embed` to refuse."""
        try:
            _layout(size, key, n_bits)
        except (CapacityError, ValueError, TypeError):
            return

    def prepare(self, image: SampledImage, *, options: RobustOptions | None = None) -> Candidates:
        """The candidates a received image offers (:class:`~.search.Candidates`)."""
        return Candidates(image, options=options)

    def decode(
        self, prepared: Any, n_bits: int, *, key: str | bytes, thorough: bool = True
    ) -> Decoded:
        """Soft bits from the best candidate (``thorough=False``: as received or despiked)."""
        res = prepared.decode(n_bits, key=key, thorough=thorough)
        return Decoded(res.bits, res.confidence, res.report)


#: The registered instance.
PROFILE = RobustProfile()
