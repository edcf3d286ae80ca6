"""What goes into the registry and what comes out: frozen dataclasses and their checks.

:class:`AssetEntry` and :class:`CopyEntry` are what a caller records (checked when built);
:class:`AssetRecord` and :class:`CopyRecord` are the rows read back, with their ids and dates.
The copy's ``params`` are stored as JSON and may never hold a key: a name ``key`` or ``secret``
at any depth is refused.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FORBIDDEN_PARAMS",
    "AssetEntry",
    "AssetRecord",
    "CopyEntry",
    "CopyRecord",
    "check_references",
    "decode_descriptor",
    "decode_params",
    "encode_descriptor",
    "encode_params",
    "normalise_payload",
]

#: Names refused in a copy's params (any case, any depth): the registry never holds a key.
FORBIDDEN_PARAMS = frozenset({"key", "secret"})

_SHA256 = re.compile(r"[0-9a-f]{64}")
_PAYLOAD = re.compile(r"[0-9a-f]{16}|mark:[0-9a-f]{64}")


def _sha256(name: str, value: object) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str of 64 hex digits, got {type(value).__name__}")
    text = value.lower()
    if not _SHA256.fullmatch(text):
        raise ValueError(f"{name} must be 64 hex digits (a SHA-256), got {value!r}")
    return text


def _count(name: str, value: object, *, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name} must be >= {low}, got {value}")
    return int(value)


def check_references(references: object) -> dict[int, bytes]:
    """Reference blobs by grid size ``n`` (>= 0), checked: a dict of int to bytes.

    Raises
    ------
    TypeError
        Not a mapping, an ``n`` that is not an int, data that is not bytes.
    ValueError
        A negative ``n``.
    """
    if not isinstance(references, Mapping):
        raise TypeError(f"references must be a mapping, got {type(references).__name__}")
    out: dict[int, bytes] = {}
    for n, data in references.items():
        if not isinstance(data, bytes | bytearray | memoryview):
            raise TypeError(f"references[{n!r}] must be bytes, got {type(data).__name__}")
        out[_count("reference n", n, low=0)] = bytes(data)
    return out


def _text(name: str, value: object) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {type(value).__name__}")
    if not value or "\x00" in value:
        raise ValueError(f"{name} must be non-empty text without NUL characters, got {value!r}")
    return value


def normalise_payload(value: object) -> str:
    """A copy's payload in its one stored form: 16 lowercase hex digits or ``mark:<sha256>``.

    Examples
    --------
    >>> normalise_payload("C0FFEE42C0FFEE42")
    'c0ffee42c0ffee42'
    """
    if not isinstance(value, str):
        raise TypeError(f"payload must be a str, got {type(value).__name__}")
    text = value.lower()
    if not _PAYLOAD.fullmatch(text):
        raise ValueError(
            f"payload must be an id of 16 hex digits or 'mark:' and a SHA-256, got {value!r}"
        )
    return text


def encode_descriptor(descriptor: NDArray[np.float64]) -> bytes:
    """The descriptor's stored bytes: float64, little-endian."""
    return np.ascontiguousarray(descriptor, dtype="<f8").tobytes()


def decode_descriptor(data: bytes) -> NDArray[np.float64]:
    """The descriptor from its stored bytes (a new, writable float64 array)."""
    return np.frombuffer(data, dtype="<f8").astype(np.float64)


def _check_params(value: Any, where: str) -> None:
    if isinstance(value, Mapping):
        for name, item in value.items():
            if not isinstance(name, str):
                raise TypeError(f"params{where}: names must be str, got {name!r}")
            if name.lower() in FORBIDDEN_PARAMS:
                raise ValueError(
                    f"params{where} has a field {name!r}: the registry never stores a key "
                    "or secret; leave it out"
                )
            _check_params(item, f"{where}.{name}")
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            _check_params(item, f"{where}[{index}]")


def encode_params(params: Mapping[str, Any]) -> str:
    """A copy's params as JSON (sorted keys); refuses ``key``/``secret`` and non-JSON values.

    Examples
    --------
    >>> encode_params({"strength": 1.5, "profile": "robust"})
    '{"profile": "robust", "strength": 1.5}'
    >>> encode_params({"options": {"Key": "x"}})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: params.options has a field 'Key': the registry never stores a key or secret; ...
    """
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping, got {type(params).__name__}")
    _check_params(params, "")
    try:
        return json.dumps(dict(params), sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"params must be plain JSON values: {exc}") from None


def decode_params(text: str) -> dict[str, Any]:
    """A copy's params from their stored JSON."""
    value = json.loads(text)
    if not isinstance(value, dict):
        raise ValueError(f"stored params are not a JSON object: {text[:60]!r}")
    return value


@dataclass(frozen=True, eq=False)
class AssetEntry:
    """An input asset, as recorded the first time a copy of it is sent out.

    Parameters
    ----------
    name : str
        The input's file name, as the studio knows it.
    input_sha256 : str
        SHA-256 of the input (``embed --registry``: of its geometry), 64 hex digits (stored
        lowercase); the asset's identity.
    vertices, faces : int
        Size of the input, >= 0.
    descriptor : (d,) float64 array
        The asset's shape descriptor, finite; every asset of a registry has the same ``d``.
    references : mapping of int to bytes
        Opaque reference data by grid size ``n`` (>= 1), made by the caller (about 100 KB to
        2 MB each), and under ``n`` = 0 what holds for every grid size (the informed reader's
        probe, a few KB); an ``n`` the registry already holds for the asset is kept as it was
        (a later embed of the asset adds the ones it lacks).
    """

    name: str
    input_sha256: str
    vertices: int
    faces: int
    descriptor: NDArray[np.float64]
    references: Mapping[int, bytes] = field(default_factory=dict)

    def __post_init__(self) -> None:
        _text("name", self.name)
        object.__setattr__(self, "input_sha256", _sha256("input_sha256", self.input_sha256))
        object.__setattr__(self, "vertices", _count("vertices", self.vertices, low=0))
        object.__setattr__(self, "faces", _count("faces", self.faces, low=0))
        descriptor = np.array(self.descriptor, dtype=np.float64)
        if descriptor.ndim != 1 or descriptor.size == 0:
            raise ValueError(f"descriptor must be a non-empty 1-D array, got {descriptor.shape}")
        if not np.all(np.isfinite(descriptor)):
            raise ValueError("descriptor must be finite (it holds NaN or inf)")
        descriptor.setflags(write=False)
        object.__setattr__(self, "descriptor", descriptor)
        object.__setattr__(self, "references", check_references(self.references))


@dataclass(frozen=True)
class CopyEntry:
    """One marked copy sent out.

    Parameters
    ----------
    payload : str
        What the copy carries: its 64-bit id as 16 hex digits, or ``mark:`` and the SHA-256
        of the mark image (stored lowercase).
    recipient : str or None
        Who received it.
    output_name : str
        The marked file's name.
    output_sha256 : str
        SHA-256 of the marked file, 64 hex digits.
    n : int
        Grid size the copy was marked at (>= 1).
    params : mapping
        The embedding's options, JSON values only; a name ``key`` or ``secret`` (any case,
        any depth) is refused with :class:`ValueError`.
    signature : bytes or None
        The copy's mark signature as the informed reader needs it, sealed under the key by the
        caller (:func:`meshwm.readers.informed.seal_signature`); opaque here.
    """

    payload: str
    recipient: str | None
    output_name: str
    output_sha256: str
    n: int
    params: Mapping[str, Any] = field(default_factory=dict)
    signature: bytes | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "payload", normalise_payload(self.payload))
        if self.recipient is not None:
            _text("recipient", self.recipient)
        _text("output_name", self.output_name)
        object.__setattr__(self, "output_sha256", _sha256("output_sha256", self.output_sha256))
        object.__setattr__(self, "n", _count("n", self.n, low=1))
        encode_params(self.params)  # refuses a key, or a value JSON cannot hold, now
        if self.signature is not None:
            if not isinstance(self.signature, bytes | bytearray | memoryview):
                raise TypeError(f"signature must be bytes, got {type(self.signature).__name__}")
            object.__setattr__(self, "signature", bytes(self.signature))


@dataclass(frozen=True)
class AssetRecord:
    """An asset as the registry holds it; ``copies`` is how many copies of it were recorded."""

    id: int
    name: str
    input_sha256: str
    vertices: int
    faces: int
    created: str
    copies: int


@dataclass(frozen=True)
class CopyRecord:
    """A recorded copy; ``created`` is UTC ISO-8601 text, ``params`` the stored JSON decoded,
    ``signature`` the sealed signature (or None)."""

    id: int
    asset_id: int
    payload: str
    recipient: str | None
    output_name: str
    output_sha256: str
    n: int
    created: str
    params: dict[str, Any]
    signature: bytes | None = None
