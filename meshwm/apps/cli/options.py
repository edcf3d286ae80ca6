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
import os
from collections.abc import Callable, Mapping
from pathlib import Path
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
    "KEY_ENV",
    "add_fpr_option",
    "add_key_options",
    "add_max_faces",
    "add_watermark_options",
    "bounded",
    "grid_size",
    "ident",
    "integer",
    "key",
    "key_of",
    "mark_size",
    "names",
    "positive_int",
    "probability",
    "read_key_file",
    "real",
    "seed",
    "watermark_params",
]

#: Side of the mark when ``--mark-size`` is not given (the bundled logo's).
DEFAULT_MARK_SIZE = 32
#: The environment variable that may hold the key (when neither --key nor --key-file is given).
KEY_ENV = "MESHWM_KEY"
#: A key file longer than this is refused (a key is a line of text or a few bytes).
MAX_KEY_FILE = 1 << 16


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
    """A 64-bit id: ``0x`` and hex digits, or up to 8 bytes of text (``parse_id``'s one rule)."""
    from meshwm.message.payload import parse_id

    try:
        return parse_id(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def key(text: str) -> str:
    """The secret key given on the command line: any non-empty string (never echoed)."""
    if not text:
        raise argparse.ArgumentTypeError("the key must not be empty")
    return text


def read_key_file(path: Path) -> bytes:
    """The key stored in ``path``: its bytes, one trailing newline (LF or CRLF) removed.

    The same text given with ``--key`` is the same key (a string key is used as its UTF-8
    bytes).  Errors name the file, never its content.

    Raises
    ------
    ValueError
        The file is missing, unreadable, a folder, larger than 64 KiB or empty.
    """
    try:
        with open(path, "rb") as stream:
            data = stream.read(MAX_KEY_FILE + 1)
    except IsADirectoryError:
        raise ValueError(f"--key-file {path}: is a folder, not a key file") from None
    except OSError as exc:
        raise ValueError(f"--key-file {path}: cannot read it ({exc.strerror or 'error'})") from None
    if len(data) > MAX_KEY_FILE:
        raise ValueError(f"--key-file {path}: larger than {MAX_KEY_FILE} bytes, not a key file")
    if data.endswith(b"\r\n"):
        data = data[:-2]
    elif data.endswith(b"\n"):
        data = data[:-1]
    if not data:
        raise ValueError(f"--key-file {path}: the file is empty")
    return data


def key_of(args: argparse.Namespace, environ: Mapping[str, str] | None = None) -> str | bytes:
    """The secret key from exactly one source: ``--key``, ``--key-file`` or ``$MESHWM_KEY``.

    Two sources at once are refused rather than ranked: a key left in the environment must
    not silently win over (or lose to) the one given on the line, since the wrong key only
    shows as "absent".  The messages name the sources, never the key.

    Raises
    ------
    ValueError
        No source, or more than one.

    Examples
    --------
    >>> key_of(argparse.Namespace(key="k", key_file=None), environ={})
    'k'
    >>> key_of(argparse.Namespace(key=None, key_file=None), environ={"MESHWM_KEY": "k"})
    'k'
    >>> key_of(argparse.Namespace(key="k", key_file=None), environ={"MESHWM_KEY": "k"})
    Traceback (most recent call last):
    ...
    ValueError: the key is given twice, by --key and by $MESHWM_KEY; give exactly one
    """
    environ = os.environ if environ is None else environ
    sources: list[tuple[str, Callable[[], str | bytes]]] = []
    given = getattr(args, "key", None)
    if given is not None:
        sources.append(("--key", lambda: given))
    path = getattr(args, "key_file", None)
    if path is not None:
        sources.append(("--key-file", lambda: read_key_file(path)))
    env = environ.get(KEY_ENV)
    if env is not None:
        sources.append((f"${KEY_ENV}", lambda: env))
    if not sources:
        raise ValueError(f"no key: give --key-file PATH, set {KEY_ENV}, or give --key KEY")
    if len(sources) > 1:
        names = " and by ".join(name for name, _ in sources)
        raise ValueError(f"the key is given twice, by {names}; give exactly one")
    name, read = sources[0]
    value = read()
    if not value:
        raise ValueError(f"the key from {name} is empty")
    return value


def add_key_options(parser: argparse.ArgumentParser) -> None:
    """``--key`` and ``--key-file``; without either the key comes from ``$MESHWM_KEY``."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--key-file",
        type=Path,
        metavar="PATH",
        help=f"read the secret key from this file (one trailing newline ignored); or set "
        f"{KEY_ENV}; exactly one key source",
    )
    group.add_argument(
        "--key",
        type=key,
        metavar="KEY",
        help="the secret key as text (visible in shell history and the process list: prefer "
        f"--key-file or {KEY_ENV})",
    )


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


def add_fpr_option(parser: argparse.ArgumentParser) -> None:
    """``--fpr``: the false-positive probability a decision allows (verify, trace)."""
    parser.add_argument(
        "--fpr",
        type=probability,
        default=1e-6,
        help="false-positive probability allowed, over all hypotheses tried (1e-6)",
    )


def add_watermark_options(parser: argparse.ArgumentParser, *, size: bool) -> None:
    """The public parameters; extraction must be given the ones embedding used.

    ``size``: add ``--size`` (embedding only; extraction reads N from the mesh).  The
    ``--profile`` choices and each profile's own options come from
    :data:`meshwm.profiles.PROFILES`: an option that applies to one profile only says so.
    """
    from meshwm.params import WatermarkParams
    from meshwm.profiles import DEFAULT_PROFILE, PROFILES

    defaults = WatermarkParams()
    add_key_options(parser)
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
