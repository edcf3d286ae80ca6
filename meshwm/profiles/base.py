"""The profile protocol: embed into a sampled geometry image, decode one.

A profile is a watermarking scheme on geometry images.  It knows nothing of meshes: the
composition (:mod:`meshwm.watermark`) gives it the cover image a mesh was sampled into, and a
reader (:mod:`meshwm.readers`) gives it the image re-derived from a received mesh.
"""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from meshwm.readers.base import SampledImage

__all__ = ["Decoded", "Embedding", "ImageDecoder", "Profile"]


class Embedding(NamedTuple):
    """A marked geometry image.

    Attributes
    ----------
    cover : (N, N, 3) float64 ndarray
        The image as given.
    marked : (N, N, 3) float64 ndarray
        The marked image (border samples bit-identical to the cover's).
    report : dict
        Figures of the embedding: ``carriers``, ``capacity_bits``, ``used_bits``, ``psnr``
        and the profile's own.
    """

    cover: NDArray[np.float64]
    marked: NDArray[np.float64]
    report: dict[str, Any]

    @property
    def changes(self) -> NDArray[np.float64]:
        """``marked - cover``: what the mark moves, sample by sample."""
        return self.marked - self.cover


class Decoded(NamedTuple):
    """Soft bits read from a geometry image.

    Attributes
    ----------
    bits : (k,) uint8 ndarray
        The bits as carried (0/1).
    confidence : (k,) float64 ndarray
        Each bit's vote over its weight, in [-1, 1], positive for 1... by magnitude: near 1 for
        a clean read, near 0 for noise.
    report : dict
        The profile's figures; ``hypotheses`` (default 1) is how many it tried, which the
        decision multiplies with the reader's.
    """

    bits: NDArray[np.uint8]
    confidence: NDArray[np.float64]
    report: dict[str, Any]


class ImageDecoder(Protocol):
    """What reads soft bits from a received image: a profile, or a carrier of its own.

    ``prepare`` does the key-independent work once, so that one received mesh can be decoded
    with many keys (a null study, a batch that tries several customers' keys).
    """

    name: str
    #: An upper bound on the ``hypotheses`` :meth:`decode` reports for one image: a decoder
    #: that stops before trying every image a reader offered counts the rest at this.
    max_hypotheses: int

    def prepare(self, image: SampledImage, *, options: Any) -> Any:
        """The key-independent analysis of a received image."""
        ...

    def decode(
        self, prepared: Any, n_bits: int, *, key: str | bytes, thorough: bool = True
    ) -> Decoded:
        """``n_bits`` soft bits of a prepared image, under ``key``.

        ``thorough=False`` tries only the image as received (and what is as cheap); a decoder
        with costly candidates (the robust profile's smoothing undone) tries them with True.
        """
        ...


class Profile(ImageDecoder, Protocol):
    """A watermarking scheme on geometry images (registered in :data:`meshwm.profiles.PROFILES`)."""

    options_type: type

    def embed(
        self, gim: NDArray[np.float64], bits: NDArray[np.uint8], *, key: str | bytes, options: Any
    ) -> Embedding:
        """Embed ``bits`` into the cover ``gim`` under ``key``."""
        ...
