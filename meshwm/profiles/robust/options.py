"""The robust profile's options (light: no numerical library is imported here)."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["DEFAULT_DISTORTION", "RobustOptions"]

#: The mark's target RMS normal displacement, relative to the geometry image's bounding-box
#: diagonal: keeps MRMS under 0.02 % on every development mesh (docs/robust.md).
DEFAULT_DISTORTION = 1.85e-4


@dataclass(frozen=True)
class RobustOptions:
    """Options of the robust profile (:mod:`meshwm.profiles.robust`).

    Attributes
    ----------
    tangential_step : float or None
        The quantisation step of the tangential components, relative to the median sample
        spacing of the level-3 approximation (the normal component takes a quarter of it).
        ``None`` (the default) calibrates it per mesh so that the mark's distortion is
        ``distortion``.  Extraction never needs it: the decoder searches the gain.
    distortion : float
        With ``tangential_step=None``: the target RMS normal displacement of the mark,
        relative to the bounding-box diagonal of the geometry image, in [1e-7, 1e-2].
        Default :data:`DEFAULT_DISTORTION`.

    Examples
    --------
    >>> RobustOptions().tangential_step is None
    True
    >>> RobustOptions(distortion=0.5)
    Traceback (most recent call last):
    ...
    ValueError: distortion must lie in [1e-7, 1e-2], got 0.5
    """

    tangential_step: float | None = field(
        default=None,
        metadata={"help": "tangential step over the local sample spacing (none: calibrated)"},
    )
    distortion: float = field(
        default=DEFAULT_DISTORTION,
        metadata={"help": "target RMS normal displacement over the bounding-box diagonal"},
    )

    def __post_init__(self) -> None:
        for name in ("tangential_step", "distortion"):
            value = getattr(self, name)
            if value is None and name == "tangential_step":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"{name} must be a number, got {type(value).__name__}")
            object.__setattr__(self, name, float(value))
        step = self.tangential_step
        if step is not None and not 1e-6 <= step <= 1.0:
            raise ValueError(f"tangential_step must lie in [1e-6, 1], got {step}")
        if not 1e-7 <= self.distortion <= 1e-2:
            raise ValueError(f"distortion must lie in [1e-7, 1e-2], got {self.distortion}")
