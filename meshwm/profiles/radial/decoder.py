"""The radial carrier's reading as an :class:`meshwm.profiles.base.ImageDecoder`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from meshwm.errors import CapacityError
from meshwm.profiles.base import Decoded
from meshwm.profiles.radial.scheme import (
    band,
    radial_layout,
    read_radial_bits,
)
from meshwm.readers.base import SampledImage

__all__ = ["DECODER", "RadialDecoder"]


class RadialDecoder:
    """Reads the radial carrier of a spherical image (:mod:`meshwm.profiles.radial`).

    It searches nothing (the step is fixed in units of the point set's RMS radius), so each
    image is one hypothesis.  The confidences are scaled by the read's reliability, the mean of
    ``cos 2·phase`` (1 when every projection sits on a lattice point, about 0 for an image that
    carries nothing).
    """

    name = "radial"
    max_hypotheses = 1

    def prepare(self, image: SampledImage, *, options: Any = None) -> tuple[int, NDArray]:
        """The image's size and its level-3 details (key-independent)."""
        samples = np.asarray(image.samples, dtype=np.float64)[..., 0]
        return samples.shape[0], band(samples)

    def decode(
        self, prepared: Any, n_bits: int, *, key: str | bytes, thorough: bool = True
    ) -> Decoded:
        """Soft bits of the carrier; zero confidence where the image has fewer slots than bits
        (no candidates: ``thorough`` changes nothing)."""
        n, coeffs = prepared
        report: dict[str, Any] = {"scheme": "radial", "hypotheses": 1}
        try:
            layout = radial_layout(n, key, n_bits)
        except CapacityError:
            zeros = np.zeros(n_bits)
            return Decoded(zeros.astype(np.uint8), zeros, report)
        per = layout.slots.shape[1]
        proj = (coeffs[layout.slots] * layout.signs).sum(axis=-1) / np.sqrt(per)
        bits, confidence = read_radial_bits(proj, layout)
        # The bits' agreement with either lattice (cos 2·phase, 1 on both, mean 0 at random)
        # scales the confidences, so a random read is weak as a whole, as the profiles' are.
        reliability = max(float(np.mean(2.0 * confidence**2 - 1.0)), 0.0)
        report["reliability"] = reliability
        return Decoded(bits, confidence * reliability, report)


#: The registered instance.
DECODER = RadialDecoder()
