"""The public parameters of a watermark: one frozen dataclass shared by embedding and extraction.

Everything extraction must know besides the key lives here, and every field has a default, so
``meshwm extract`` needs only the mesh, the key and the mark's size.  The key string itself is
*not* a field: it is the secret, passed separately, so a parameter file can be shared or logged.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from meshwm.signal.wavelet import MRR_LEVEL3_KEYS

__all__ = ["CHANNELS", "DEFAULT_STEP", "PROFILES", "WatermarkParams"]

#: Canonical-frame axes that can carry bits (see :mod:`meshwm.watermark`).
CHANNELS = ("x", "y", "z")

#: The embedding schemes: ``"paper"`` is the paper's scheme made exact (section 3);
#: ``"robust"`` is meshwm's default for real pipelines (see docs/robust.md).
PROFILES = ("paper", "robust")

#: Default quantisation step of each profile (see :attr:`WatermarkParams.step`); ``None``:
#: calibrated per mesh to :attr:`WatermarkParams.distortion`.
DEFAULT_STEP: dict[str, float | None] = {"paper": 0.006, "robust": None}


@dataclass(frozen=True)
class WatermarkParams:
    """Parameters of the watermark (section 3 of the paper, and our choices where it is silent).

    Attributes
    ----------
    profile : str
        ``"paper"`` (the paper's scheme, faithful, for the side-by-side benchmark) or
        ``"robust"`` (meshwm's scheme for real pipelines, :mod:`meshwm.profiles.robust`).  Default
        ``"robust"``.
    size : int
        Geometry-image size N (a power of two, 64..2048).  Default 256.
    arnold_iterations : int
        Arnold transform iterations on the mark (the paper's "key"; it uses 5).  Default 5.
    channels : tuple of str
        Canonical-frame axes whose coefficients carry bits; the paper uses x and y ("z to
        increase capacity").  Default ``("x", "y")``.
    bands : tuple of str
        MRR level-3 matrices that carry bits (keys of :func:`meshwm.signal.wavelet.mrr_decompose`).
        Default: all 16 level-3 matrices of the paper's tree.
    step : float, optional
        Quantisation step.  ``"paper"``: of the remainder rule, relative to the model's RMS
        radius (so a scaled copy marks identically); ``None`` (the default) means 0.006, which
        keeps the mark's own distortion under MRMS 0.02 % of the bounding-box diagonal on every
        development mesh.  ``"robust"``: the tangential step relative to the local sample
        spacing; ``None`` (the default) calibrates it per mesh so that the mark's distortion is
        ``distortion`` (extraction never needs it: the decoder searches the gain).
    distortion : float
        ``"robust"`` with ``step=None``: the target RMS normal displacement of the mark,
        relative to the bounding-box diagonal of the geometry image.  Default 1.85e-4, which
        keeps MRMS under 0.02 % on every development mesh (docs/robust.md).
    remainder_one, remainder_zero : float
        The paper's i and j (i > j), as fractions of the step: a coefficient carries 1 when
        its dithered remainder is set to ``remainder_one`` and 0 when set to
        ``remainder_zero``.  Defaults 0.75 and 0.25, half a step apart, the largest margin.
    min_carriers : int
        Each bit is carried by at least this many coefficients; where the fuzzy mask's HIGH and
        HIGHER coefficients are fewer, others are added (best fuzzy class first, then in
        the keyed order).  Default 3.

    Examples
    --------
    >>> p = WatermarkParams(step=0.02)
    >>> WatermarkParams.from_dict(p.to_dict()) == p
    True
    """

    profile: str = "robust"
    size: int = 256
    arnold_iterations: int = 5
    channels: tuple[str, ...] = ("x", "y")
    bands: tuple[str, ...] = MRR_LEVEL3_KEYS
    step: float | None = None
    distortion: float = 1.85e-4
    remainder_one: float = 0.75
    remainder_zero: float = 0.25
    min_carriers: int = 3

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ValueError(f"unknown profile {self.profile!r}; valid: {', '.join(PROFILES)}")
        if self.step is None:
            object.__setattr__(self, "step", DEFAULT_STEP[self.profile])
        _integer(self.size, "size")
        if self.size < 64 or self.size > 2048 or self.size & (self.size - 1):
            raise ValueError(f"size must be a power of two in 64..2048, got {self.size}")
        _integer(self.arnold_iterations, "arnold_iterations")
        if self.arnold_iterations < 0 or self.arnold_iterations > 10_000:
            raise ValueError(
                f"arnold_iterations must lie in 0..10000, got {self.arnold_iterations}"
            )
        object.__setattr__(self, "channels", _names(self.channels, CHANNELS, "channels"))
        object.__setattr__(self, "bands", _names(self.bands, MRR_LEVEL3_KEYS, "bands"))
        for name in ("step", "distortion", "remainder_one", "remainder_zero"):
            value = getattr(self, name)
            if value is None and name == "step":
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError(f"{name} must be a number, got {type(value).__name__}")
            object.__setattr__(self, name, float(value))
        if self.step is not None and not 1e-6 <= self.step <= 1.0:
            raise ValueError(f"step must lie in [1e-6, 1], got {self.step}")
        if not 1e-7 <= self.distortion <= 1e-2:
            raise ValueError(f"distortion must lie in [1e-7, 1e-2], got {self.distortion}")
        if not 0.0 <= self.remainder_zero < self.remainder_one < 1.0:
            raise ValueError(
                "need 0 <= remainder_zero < remainder_one < 1 (the paper's j < i), got "
                f"{self.remainder_zero} and {self.remainder_one}"
            )
        _integer(self.min_carriers, "min_carriers")
        if not 1 <= self.min_carriers <= 64:
            raise ValueError(f"min_carriers must lie in 1..64, got {self.min_carriers}")

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (tuples become lists)."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> WatermarkParams:
        """The inverse of :meth:`to_dict`; unknown keys are an error."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; valid: {sorted(known)}")
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


def _integer(value: object, name: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")


def _names(value: object, valid: tuple[str, ...], name: str) -> tuple[str, ...]:
    if isinstance(value, str):
        value = (value,)
    items = tuple(value)  # type: ignore[arg-type]
    if not items:
        raise ValueError(f"{name} must not be empty; valid: {', '.join(valid)}")
    bad = [v for v in items if v not in valid]
    if bad:
        raise ValueError(f"unknown {name} {bad}; valid: {', '.join(valid)}")
    if len(set(items)) != len(items):
        raise ValueError(f"{name} has duplicates: {list(items)}")
    # Canonical order, so ("y", "x") and ("x", "y") are the same parameters.
    return tuple(v for v in valid if v in items)
