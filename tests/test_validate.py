"""Tests for :mod:`meshwm._validate`'s mesh check: read-only arrays handed on as they are."""

from __future__ import annotations

import numpy as np
import pytest

from meshwm._digest import freeze, is_frozen
from meshwm._validate import check_mesh
from meshwm.errors import MeshError


def test_check_mesh_frozen_keeps_read_only_arrays_and_freezes_copies() -> None:
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    f = np.array([[0, 1, 2]])
    # Writable arrays: copies, read-only (the caller's stay writable and unshared).
    cv, cf = check_mesh(v, f, frozen=True)
    assert cv is not v and cf is not f and not np.shares_memory(cv, v)
    assert is_frozen(cv) and is_frozen(cf) and v.flags.writeable and f.flags.writeable
    # Read-only arrays: the same objects, checked (no copy), so their digests are kept.
    again = check_mesh(cv, cf, frozen=True)
    assert again[0] is cv and again[1] is cf
    # Without the option: writable copies, as always.
    wv, wf = check_mesh(cv, cf)
    assert wv is not cv and wv.flags.writeable and wf.flags.writeable
    # A read-only view of writable memory is not immutable: copied.
    view = v[:]
    view.flags.writeable = False
    assert check_mesh(view, f, frozen=True)[0] is not view
    # Read-only arrays are still checked.
    bad = np.array([[0, 1, 5]])
    freeze(bad)
    with pytest.raises(MeshError, match="face indices"):
        check_mesh(cv, bad, frozen=True)
