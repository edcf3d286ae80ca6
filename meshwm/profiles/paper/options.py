"""The paper profile's options (light: no numerical library is imported here)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from meshwm.signal.wavelet import MRR_LEVEL3_KEYS

__all__ = ["CHANNELS", "DEFAULT_STEP", "PaperOptions"]

#: Canonical-frame axes that can carry bits (see :mod:`meshwm.profiles.paper`).
CHANNELS = ("x", "y", "z")
#: Default step of the remainder rule, relative to the model's RMS radius: keeps the mark's own
#: distortion under MRMS 0.02 % of the bounding-box diagonal on every development mesh.
DEFAULT_STEP = 0.006


def _names(value: Iterable[str] | str, valid: tuple[str, ...], name: str) -> tuple[str, ...]:
    if isinstance(value, str):
        value = (value,)
    items = tuple(value)
    if not items:
        raise ValueError(f"{name} must not be empty; valid: {', '.join(valid)}")
    bad = [v for v in items if v not in valid]
    if bad:
        raise ValueError(f"unknown {name} {bad}; valid: {', '.join(valid)}")
    if len(set(items)) != len(items):
        raise ValueError(f"{name} has duplicates: {list(items)}")
    # Canonical order, so ("y", "x") and ("x", "y") are the same options.
    return tuple(v for v in valid if v in items)


@dataclass(frozen=True)
class PaperOptions:
    """Options of the paper's scheme (:mod:`meshwm.profiles.paper`).

    Attributes
    ----------
    step : float
        Quantisation step of the remainder rule, relative to the model's RMS radius (so a
        scaled copy marks identically), in [1e-6, 1].  Default :data:`DEFAULT_STEP`.
    channels : tuple of str
        Canonical-frame axes whose coefficients carry bits; the paper uses x and y ("z to
        increase capacity").  Default ``("x", "y")``.
    bands : tuple of str
        MRR level-3 matrices that carry bits (keys of
        :func:`meshwm.signal.wavelet.mrr_decompose`).  Default: all 16 level-3 matrices of the
        paper's tree.
    remainder_one, remainder_zero : float
        The paper's i and j (i > j), as fractions of the step: a coefficient carries 1 when
        its dithered remainder is set to ``remainder_one`` and 0 when set to
        ``remainder_zero``.  Defaults 0.75 and 0.25, half a step apart, the largest margin.
    min_carriers : int
        Each bit is carried by at least this many coefficients; where the fuzzy mask's HIGH and
        HIGHER coefficients are fewer, others are added (best fuzzy class first, then in the
        keyed order).  Default 3.

    Examples
    --------
    >>> PaperOptions(channels=("y", "x")) == PaperOptions()
    True
    """

    step: float = field(
        default=DEFAULT_STEP,
        metadata={"help": "remainder-rule step over the model's RMS radius"},
    )
    channels: tuple[str, ...] = field(
        default=("x", "y"),
        metadata={"help": "canonical axes that carry the mark, comma-separated"},
    )
    bands: tuple[str, ...] = MRR_LEVEL3_KEYS
    remainder_one: float = 0.75
    remainder_zero: float = 0.25
    min_carriers: int = 3

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", _names(self.channels, CHANNELS, "channels"))
        object.__setattr__(self, "bands", _names(self.bands, MRR_LEVEL3_KEYS, "bands"))
        for name in ("step", "remainder_one", "remainder_zero"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"{name} must be a number, got {type(value).__name__}")
            object.__setattr__(self, name, float(value))
        if not 1e-6 <= self.step <= 1.0:
            raise ValueError(f"step must lie in [1e-6, 1], got {self.step}")
        if not 0.0 <= self.remainder_zero < self.remainder_one < 1.0:
            raise ValueError(
                "need 0 <= remainder_zero < remainder_one < 1 (the paper's j < i), got "
                f"{self.remainder_zero} and {self.remainder_one}"
            )
        carriers = self.min_carriers
        if isinstance(carriers, bool) or not isinstance(carriers, int):
            raise TypeError(f"min_carriers must be an integer, got {type(carriers).__name__}")
        if not 1 <= carriers <= 64:
            raise ValueError(f"min_carriers must lie in 1..64, got {carriers}")
