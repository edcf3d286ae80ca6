"""A key for memoising pure functions of numpy arrays: their shapes, dtypes and a digest."""

from __future__ import annotations

import hashlib
import threading
import weakref
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any, TypeVar, cast

import numpy as np
from numpy.typing import NDArray

T = TypeVar("T")

__all__ = ["LastResult", "arrays_key", "freeze", "is_frozen"]


def arrays_key(*arrays: NDArray) -> tuple:
    """Shape, dtype and a SHA-256 digest of the bytes of each array.

    A read-only array over read-only memory (:func:`freeze`) is taken as immutable: its digest
    is kept with it (by identity, while it lives) and not computed again.  The pipeline freezes the
    arrays it hands from stage to stage (a cleaned mesh's, a surface's, its map's faces); at
    537k vertices an embedding asked for the digests of one face array ten times, 25 ms each.

    Examples
    --------
    >>> a = np.arange(6.0).reshape(2, 3)
    >>> arrays_key(a) == arrays_key(a.copy()), arrays_key(a) == arrays_key(a + 1)
    (True, False)
    """
    return tuple((a.shape, a.dtype.str, _digest(a)) for a in arrays)


#: Digests of frozen arrays by ``id``, with a weak reference that drops the entry when the
#: array goes (a new array may take its ``id``).
_FROZEN: dict[int, tuple[weakref.ref, bytes]] = {}
_FROZEN_LOCK = threading.Lock()


def _digest(a: NDArray) -> bytes:
    """SHA-256 of the array's bytes in C order.

    SHA-256, not BLAKE2b: with the SHA extensions of current x86 and ARM cores it hashes twice
    as fast (1.9 against 0.9 GB/s here), and an embedding at 2M vertices digests gigabytes.
    """
    frozen = is_frozen(a)
    if frozen:
        with _FROZEN_LOCK:
            hit = _FROZEN.get(id(a))
        if hit is not None and hit[0]() is a:
            return hit[1]
    # The array's own buffer (``tobytes`` would copy it first: 100 MB at 2M faces).
    digest = hashlib.sha256(_buffer(a)).digest()
    if frozen:
        ident = id(a)

        def forget(_: weakref.ref, ident: int = ident) -> None:
            with _FROZEN_LOCK:
                entry = _FROZEN.get(ident)
                if entry is not None and entry[0]() is None:
                    del _FROZEN[ident]

        with _FROZEN_LOCK:
            _FROZEN[ident] = (weakref.ref(a, forget), digest)
    return digest


def is_frozen(a: NDArray) -> bool:
    """Read-only, and so is every array it is a view of, down to one that owns its memory (a
    view of a read-only array cannot be made writeable; the owner could, and the pipeline
    never does)."""
    while isinstance(a, np.ndarray):
        if a.flags.writeable:
            return False
        if a.base is None:
            return True
        a = a.base
    return False


def freeze(*arrays: NDArray) -> None:
    """Make arrays read-only, so that :func:`arrays_key` keeps their digests (a view's only
    where what it views is read-only too)."""
    for a in arrays:
        a.flags.writeable = False


def _buffer(a: NDArray) -> memoryview:
    """The bytes of ``a`` in C order, without a copy where it is contiguous."""
    return memoryview(np.ascontiguousarray(a).reshape(-1).view(np.uint8).data)


class LastResult:
    """The last result of a pure function of arrays, by a key such as :func:`arrays_key`'s.

    One entry: a mesh's pipeline asks for the same connectivity work several times in a row,
    and a second entry would only hold memory.  Thread-safe; the caller makes the arrays it
    stores read-only.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._key: tuple | None = None
        self._value: Any = None
        self._making: dict[tuple, Future[Any]] = {}

    def get(self, key: tuple) -> Any:
        """The value stored under ``key``, or None."""
        with self._lock:
            return self._value if self._key == key else None

    def put(self, key: tuple, value: Any) -> None:
        """Keep ``value`` under ``key``, dropping the last one."""
        with self._lock:
            self._key, self._value = key, value

    def made_once(self, key: tuple, make: Callable[[], T], *, keep: bool = True) -> T:
        """The value stored under ``key``, else ``make()``, kept if ``keep``; made once.

        Where another thread is making the same key's value, it is waited for rather than made
        again (what ``make`` raised there is raised here too).  The kept embedding smooths a
        mesh in a second thread while the first cleans it, and both ask for the edges of the
        same faces at once: each made them (igea at 134k vertices, 0.06 and 0.11 s on two
        cores that a third thread shares).
        """
        with self._lock:
            if self._key == key:
                return cast(T, self._value)
            making = self._making.get(key)
            mine = making is None
            if mine:
                making = self._making[key] = Future()
        assert making is not None
        if not mine:
            return cast(T, making.result())
        try:
            value = make()
        except BaseException as exc:
            with self._lock:
                del self._making[key]
            making.set_exception(exc)
            raise
        with self._lock:
            if keep:
                self._key, self._value = key, value
            del self._making[key]
        making.set_result(value)
        return value
