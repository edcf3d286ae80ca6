"""The public parameters of a watermark: one frozen dataclass shared by embedding and extraction.

Everything extraction must know besides the key lives here, and every field has a default, so
``meshwm extract`` needs only the mesh, the key and the mark's size.  The key string itself is
*not* a field: it is the secret, passed separately, so a parameter file can be shared or logged.
What only one profile uses lives in that profile's options (:mod:`meshwm.profiles`), so no
field means two things.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from meshwm._validate import DEFAULT_SIZE, check_integer, check_square_pow2
from meshwm.profiles import DEFAULT_PROFILE, PROFILES, options_type

__all__ = ["WatermarkParams"]


@dataclass(frozen=True)
class WatermarkParams:
    """Parameters of the watermark (section 3 of the paper, and our choices where it is silent).

    Attributes
    ----------
    profile : str
        A key of :data:`meshwm.profiles.PROFILES`: ``"robust"`` (meshwm's scheme for real
        pipelines, the default) or ``"paper"`` (the paper's scheme, for the side-by-side
        benchmark).
    size : int
        Geometry-image size N (a power of two in :data:`meshwm._validate.SIZE_RANGE`).
        Default 256.
    arnold_iterations : int
        Arnold transform iterations on the mark (the paper's "key"; it uses 5), 0..10000.
        Default 5.
    options : dataclass or None
        The profile's own options (:class:`~meshwm.profiles.robust.options.RobustOptions`,
        :class:`~meshwm.profiles.paper.options.PaperOptions`); ``None`` (the default) means
        the profile's defaults.

    Examples
    --------
    >>> from meshwm.profiles.paper import PaperOptions
    >>> p = WatermarkParams(profile="paper", options=PaperOptions(step=0.02))
    >>> WatermarkParams.from_dict(p.to_dict()) == p
    True
    >>> WatermarkParams().options
    RobustOptions(tangential_step=None, distortion=0.000185)
    """

    profile: str = DEFAULT_PROFILE
    size: int = DEFAULT_SIZE
    arnold_iterations: int = 5
    options: Any = None

    def __post_init__(self) -> None:
        if not isinstance(self.profile, str) or self.profile not in PROFILES:
            raise ValueError(f"unknown profile {self.profile!r}; valid: {', '.join(PROFILES)}")
        object.__setattr__(self, "size", check_square_pow2(self.size, name="size"))
        iterations = check_integer(
            self.arnold_iterations, name="arnold_iterations", low=0, high=10_000
        )
        object.__setattr__(self, "arnold_iterations", iterations)
        kind = options_type(self.profile)
        if self.options is None:
            object.__setattr__(self, "options", kind())
        elif not isinstance(self.options, kind):
            raise TypeError(
                f"options of the {self.profile!r} profile must be {kind.__name__}, "
                f"got {type(self.options).__name__}"
            )

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (tuples become lists; the options a dict of their own)."""
        options = {
            k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.options).items()
        }
        return {
            "profile": self.profile,
            "size": self.size,
            "arnold_iterations": self.arnold_iterations,
            "options": options,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> WatermarkParams:
        """The inverse of :meth:`to_dict`; unknown keys are an error."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown}; valid: {sorted(known)}")
        values = dict(data)
        raw = values.pop("options", None)
        if raw is not None:
            kind = options_type(values.get("profile", DEFAULT_PROFILE))
            valid = {f.name for f in fields(kind)}
            bad = sorted(set(raw) - valid)
            if bad:
                raise ValueError(f"unknown option(s) {bad}; valid: {sorted(valid)}")
            values["options"] = kind(
                **{k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()}
            )
        return cls(**values)
