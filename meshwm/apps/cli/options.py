"""Option types shared by the commands, and the watermark options group.

Each type turns the text of one option into a value or raises :class:`argparse.ArgumentTypeError`,
which argparse shows as ``meshwm: error: argument --NAME: MESSAGE``.  Integer bounds are checked
by :func:`meshwm._validate.check_integer` and :func:`meshwm._validate.check_square_pow2`, the
checks the library itself uses, so the CLI states no bound of its own.

Nothing heavy is imported here: :mod:`meshwm.params` (which loads PyWavelets) is imported by
:func:`add_watermark_options`, and the mark and payload modules (Pillow, reedsolo) by the types
that need them, so ``meshwm --help`` loads neither.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from meshwm._validate import (
    DEFAULT_MAX_FACES,
    DEFAULT_SIZE,
    SIZE_RANGE,
    check_integer,
    check_square_pow2,
)

if TYPE_CHECKING:  # pragma: no cover - for type checkers only
    from meshwm.params import WatermarkParams

__all__ = [
    "DEFAULT_MARK_SIZE",
    "add_max_faces",
    "add_watermark_options",
    "bounded",
    "grid_size",
    "ident",
    "integer",
    "key",
    "mark_size",
    "names",
    "positive_int",
    "probability",
    "real",
    "seed",
    "watermark_params",
]

#: Side of the mark when ``--mark-size`` is not given (the bundled logo's).
DEFAULT_MARK_SIZE = 32


def integer(
    text: str, *, name: str = "a number", low: int | None = None, high: int | None = None
) -> int:
    """A whole number in ``[low, high]`` (either bound optional), checked by ``check_integer``.

    The error is in the CLI's voice, ``expected NAME in LOW..HIGH, got VALUE``.

    Examples
    --------
    >>> integer("12", low=1)
    12
    >>> integer("0", low=1)
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a number >= 1, got 0
    >>> integer("300", name="a mark size", low=8, high=256)
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a mark size in 8..256, got 300
    """
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    try:
        return check_integer(value, name=name, low=low, high=high)
    except ValueError:
        if low is not None and high is not None:
            bounds = f"in {low}..{high}"
        else:
            bounds = f">= {low}" if low is not None else f"<= {high}"
        raise argparse.ArgumentTypeError(f"expected {name} {bounds}, got {value}") from None


def positive_int(text: str) -> int:
    """A whole number >= 1 (``--max-faces``, ``--jobs``)."""
    return integer(text, low=1)


def seed(text: str) -> int:
    """A random seed: a whole number >= 0."""
    return integer(text, low=0)


def bounded(name: str, low: int, high: int) -> Callable[[str], int]:
    """The type of a whole number in ``low..high``; ``name`` says what it counts in errors."""

    def parse(text: str) -> int:
        return integer(text, name=name, low=low, high=high)

    return parse


def grid_size(text: str) -> int:
    """A geometry-image size N: a power of two in :data:`meshwm._validate.SIZE_RANGE`."""
    try:
        return check_square_pow2(integer(text), name="the size")
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def mark_size(text: str) -> int:
    """The side of a square mark, in :data:`meshwm.message.mark.MARK_SIZE_RANGE`."""
    from meshwm.message.mark import MARK_SIZE_RANGE  # Pillow: only when a mark size is given

    low, high = MARK_SIZE_RANGE
    return integer(text, name="a mark size", low=low, high=high)


def names(text: str) -> tuple[str, ...]:
    """A comma-separated list of names (the options dataclass checks which are valid)."""
    items = tuple(t.strip() for t in text.split(",") if t.strip())
    if not items:
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of names, got {text!r}")
    return items


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def probability(text: str) -> float:
    """A probability strictly between 0 and 1."""
    value = _number(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"expected a probability in (0, 1), got {text}")
    return value


def real(text: str) -> float:
    """A finite number."""
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return value


def ident(text: str) -> bytes:
    """A 64-bit id: 16 hex digits or 8 bytes of text (:func:`meshwm.message.payload.parse_id`)."""
    from meshwm.message.payload import parse_id

    try:
        return parse_id(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def key(text: str) -> str:
    """The secret key: any non-empty string."""
    if not text:
        raise argparse.ArgumentTypeError("the key must not be empty")
    return text


def add_max_faces(parser: argparse.ArgumentParser) -> None:
    """``--max-faces``: the refusal limit of :func:`meshwm.mesh.io.read_mesh`."""
    parser.add_argument(
        "--max-faces",
        type=positive_int,
        default=DEFAULT_MAX_FACES,
        help=f"refuse inputs with more faces ({DEFAULT_MAX_FACES})",
    )


def _profile_options() -> list[tuple[str, Any]]:
    """``(profile, field)`` for every profile option that has a command-line help text."""
    from dataclasses import fields

    from meshwm.profiles import PROFILES, options_type

    return [
        (name, f) for name in PROFILES for f in fields(options_type(name)) if "help" in f.metadata
    ]


def _flag(field_name: str) -> str:
    return "--" + field_name.replace("_", "-")


def add_watermark_options(parser: argparse.ArgumentParser, *, size: bool) -> None:
    """The public parameters; extraction must be given the ones embedding used.

    ``size``: add ``--size`` (embedding only; extraction reads N from the mesh).  The
    ``--profile`` choices and each profile's own options come from
    :data:`meshwm.profiles.PROFILES`: an option that applies to one profile only says so.
    """
    from meshwm.params import WatermarkParams
    from meshwm.profiles import DEFAULT_PROFILE, PROFILES

    defaults = WatermarkParams()
    parser.add_argument("--key", type=key, required=True, help="the secret key (any string)")
    summaries = "; ".join(f"'{p.name}': {p.summary}" for p in PROFILES.values())
    parser.add_argument(
        "--profile",
        choices=tuple(PROFILES),
        default=DEFAULT_PROFILE,
        help=f"embedding scheme ({DEFAULT_PROFILE}): {summaries}",
    )
    if size:
        low, high = SIZE_RANGE
        parser.add_argument(
            "--size",
            type=grid_size,
            default=DEFAULT_SIZE,
            help=f"geometry-image size N, a power of two {low}..{high} ({DEFAULT_SIZE})",
        )
    for profile, f in _profile_options():
        default = ",".join(f.default) if isinstance(f.default, tuple) else f.default
        default = "none" if default is None else default
        parser.add_argument(
            _flag(f.name),
            type=names if "tuple" in str(f.type) else real,
            default=None,
            help=f"{f.metadata['help']} ('{profile}' profile only; default {default})",
        )
    parser.add_argument(
        "--arnold-iterations",
        type=integer,
        default=defaults.arnold_iterations,
        help=f"Arnold scrambling iterations of the mark ({defaults.arnold_iterations})",
    )
    add_max_faces(parser)


def watermark_params(args: argparse.Namespace) -> WatermarkParams:
    """The :class:`~meshwm.params.WatermarkParams` that the watermark options spell.

    Raises :class:`ValueError` for an option of another profile than ``--profile``.
    """
    from meshwm.params import WatermarkParams
    from meshwm.profiles import options_type

    given: dict[str, Any] = {}
    for profile, f in _profile_options():
        value = getattr(args, f.name, None)
        if value is None:
            continue
        if profile != args.profile:
            own = [_flag(g.name) for p, g in _profile_options() if p == args.profile]
            raise ValueError(
                f"{_flag(f.name)} is an option of the '{profile}' profile; "
                f"the '{args.profile}' profile takes {', '.join(own) or 'no options'}"
            )
        given[f.name] = value
    return WatermarkParams(
        profile=args.profile,
        size=getattr(args, "size", DEFAULT_SIZE),
        options=options_type(args.profile)(**given),
        arnold_iterations=args.arnold_iterations,
    )
