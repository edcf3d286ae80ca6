"""Tests for :mod:`meshwm._digest`: memo keys of arrays, kept for frozen ones."""

from __future__ import annotations

import gc
import hashlib

import numpy as np
import pytest

from meshwm import _digest
from meshwm._digest import arrays_key, freeze

_SHA256 = hashlib.sha256  # the real one: the fixture counts the calls of the module's


def _sha(a: np.ndarray) -> bytes:
    return _SHA256(np.ascontiguousarray(a).tobytes()).digest()


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The number of digests computed (not taken from the frozen arrays' store)."""
    calls = [0]

    def sha256(data: object) -> object:
        calls[0] += 1
        return _SHA256(data)

    monkeypatch.setattr(_digest.hashlib, "sha256", sha256)
    return calls


def test_a_frozen_arrays_digest_is_computed_once_and_is_its_bytes(counted):
    a = np.random.default_rng(0).normal(size=(1000, 3))
    freeze(a)
    keys = [arrays_key(a) for _ in range(5)]
    assert counted[0] == 1
    assert keys[0] == keys[-1] == ((a.shape, a.dtype.str, _sha(a)),)
    # A view of a frozen array is frozen; the same numbers in a writeable copy hash alike.
    view = a[::2]
    assert arrays_key(view) == arrays_key(view) == ((view.shape, "<f8", _sha(view)),)
    assert counted[0] == 2
    assert arrays_key(a.copy()) == keys[0] and counted[0] == 3


def test_writeable_arrays_and_views_of_them_are_hashed_every_time(counted):
    a = np.arange(30.0).reshape(10, 3)  # a view of a writeable array
    first = arrays_key(a)
    a[0, 0] = -1.0  # a writeable array may change between two keys
    assert arrays_key(a) != first and counted[0] == 2
    a.flags.writeable = False  # read-only, but its base is not: still hashed each time
    arrays_key(a)
    arrays_key(a)
    assert counted[0] == 4


def test_a_frozen_arrays_entry_goes_with_it():
    a = np.ones((100, 3))
    freeze(a)
    arrays_key(a)
    ident = id(a)
    assert ident in _digest._FROZEN
    del a
    gc.collect()
    assert ident not in _digest._FROZEN


def test_a_surfaces_arrays_are_frozen(spot_mesh):
    from meshwm.gim.surface import surface_of

    v, f = spot_mesh
    s = surface_of(v, f)
    for a in (s.positions, s.inverse, s.faces, s.used, s.clean_to_position):
        assert not a.flags.writeable
    assert v.flags.writeable and f.flags.writeable  # the caller's arrays are not touched


def test_a_value_asked_for_by_two_threads_at_once_is_made_once():
    import threading
    import time

    from meshwm._digest import LastResult

    memo = LastResult()
    calls = []
    started = threading.Event()

    def make():
        calls.append(threading.current_thread().name)
        started.set()
        time.sleep(0.2)  # the second thread asks meanwhile
        return "edges"

    got = []
    first = threading.Thread(target=lambda: got.append(memo.made_once(("k",), make)))
    first.start()
    started.wait()
    got.append(memo.made_once(("k",), make))  # waits for the first thread's
    first.join()
    assert got == ["edges", "edges"] and len(calls) == 1
    assert memo.get(("k",)) == "edges"
    assert memo.made_once(("other",), lambda: 7, keep=False) == 7
    assert memo.get(("other",)) is None and memo.get(("k",)) == "edges"


def test_what_making_raised_is_raised_to_every_asker_and_nothing_is_kept():
    import threading
    import time

    from meshwm._digest import LastResult

    memo = LastResult()
    release = threading.Event()
    started = threading.Event()
    calls = []

    def make():
        calls.append(1)
        started.set()
        release.wait(5)
        raise ValueError("bad faces")

    errors = []

    def ask():
        try:
            memo.made_once(("k",), make)
        except ValueError as exc:
            errors.append(str(exc))

    first = threading.Thread(target=ask)
    first.start()
    started.wait()
    second = threading.Thread(target=ask)
    second.start()
    time.sleep(0.2)  # the second is waiting for the first's
    release.set()
    first.join()
    second.join()
    assert errors == ["bad faces", "bad faces"] and len(calls) == 1
    assert memo.get(("k",)) is None
    assert memo.made_once(("k",), lambda: 1) == 1  # made afresh after the failure
