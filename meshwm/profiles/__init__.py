"""Profiles: watermarking schemes on geometry images, as a registry.

A profile embeds bits into a sampled geometry image (the marked image and a report) and decodes
soft bits from one a reader re-derived (:class:`~meshwm.profiles.base.Profile`).  Each profile
is a sub-package with its options (a frozen dataclass, light to import), its method, and a
``profile`` module holding the registered instance ``PROFILE``.  :data:`PROFILES` is what the
command line's ``--profile`` choices, its help and the benchmark read.

To add a profile: a sub-package like :mod:`meshwm.profiles.robust` and one entry here.

:data:`CARRIERS` are schemes a user does not choose: the second carrier of a mesh kept as it
is (:mod:`meshwm.profiles.radial`), whose images a reader marks with their ``scheme``.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from meshwm.profiles.base import ImageDecoder, Profile

__all__ = [
    "CARRIERS",
    "DEFAULT_PROFILE",
    "PROFILES",
    "ProfileInfo",
    "get_decoder",
    "get_profile",
    "options_type",
]


@dataclass(frozen=True)
class ProfileInfo:
    """A registry entry: where the profile lives and what it is for (for ``--help``).

    ``strength`` names the option that sets how strong the mark is (the benchmark varies it
    to match a PSNR).
    """

    name: str
    package: str
    options: str
    strength: str
    summary: str


#: The registered profiles, by name.
PROFILES: dict[str, ProfileInfo] = {
    "robust": ProfileInfo(
        "robust",
        "meshwm.profiles.robust",
        "RobustOptions",
        "tangential_step",
        "meshwm's scheme for real pipelines: survives smoothing, quantisation, noise, cropping",
    ),
    "paper": ProfileInfo(
        "paper",
        "meshwm.profiles.paper",
        "PaperOptions",
        "step",
        "the paper's scheme, made exact, for comparison",
    ),
}

#: The profile used unless another is asked for.
DEFAULT_PROFILE = "robust"

#: Decoders of images of their own kind, by the ``scheme`` a reader gives them: module path
#: of an object ``DECODER``.
CARRIERS: dict[str, str] = {"radial": "meshwm.profiles.radial.decoder"}


def _info(name: str) -> ProfileInfo:
    if name not in PROFILES:
        raise ValueError(f"unknown profile {name!r}; valid: {', '.join(PROFILES)}")
    return PROFILES[name]


def options_type(name: str) -> Any:
    """The options dataclass of the profile ``name`` (imports no numerical library)."""
    info = _info(name)
    return getattr(importlib.import_module(info.package + ".options"), info.options)


def get_profile(name: str) -> Profile:
    """The profile registered as ``name``.

    Examples
    --------
    >>> get_profile("paper").name
    'paper'
    >>> get_profile("fast")
    Traceback (most recent call last):
    ...
    ValueError: unknown profile 'fast'; valid: robust, paper
    """
    profile: Profile = importlib.import_module(_info(name).package + ".profile").PROFILE
    return profile


def get_decoder(scheme: str | None, profile: str) -> ImageDecoder:
    """What decodes an image of ``scheme`` (a key of :data:`CARRIERS`), else ``profile``'s.

    Examples
    --------
    >>> get_decoder(None, "paper").name, get_decoder("radial", "robust").name
    ('paper', 'radial')
    """
    if scheme is None:
        return get_profile(profile)
    if scheme not in CARRIERS:
        raise ValueError(f"unknown scheme {scheme!r}; valid: {', '.join(CARRIERS)}")
    decoder: ImageDecoder = importlib.import_module(CARRIERS[scheme]).DECODER
    return decoder
