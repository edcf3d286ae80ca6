"""Tests for :mod:`meshwm.watermark.assets`: what is refused before any marking, and why.

Marking itself is exercised through the command line (``tests/apps/cli/test_cli_assets.py``);
these need no mesh large enough to carry a payload, so they run in milliseconds.
"""

from __future__ import annotations

import numpy as np
import pytest

from meshwm.errors import CapacityError, MeshError
from meshwm.mesh.asset import read_asset
from meshwm.watermark.assets import MIN_VERTICES_PER_BIT, embed_asset, verify_asset

TWO_OBJECTS = (
    "o lid\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    "o bolt\nv 5 0 0\nv 6 0 0\nv 5 1 0\nv 5 0 1\nf 5 7 6\nf 5 6 8\nf 5 8 7\nf 6 7 8\n"
)


@pytest.fixture
def small(tmp_path):
    path = tmp_path / "small.obj"
    path.write_text(TWO_OBJECTS)
    return read_asset(path)


def test_a_file_whose_meshes_are_all_too_small_is_a_capacity_error(small):
    with pytest.raises(CapacityError) as info:
        embed_asset(small, key="k", ident=b"VENDOR_A", distances=False)
    floor = MIN_VERTICES_PER_BIT * 256
    assert str(info.value) == (
        f"no mesh could be marked (lid: too small for the 256-bit payload: 4 vertices, at least "
        f"{floor} needed; bolt: too small for the 256-bit payload: 4 vertices, at least "
        f"{floor} needed)"
    )


def test_the_logo_floor_suggests_an_id(small):
    with pytest.raises(
        CapacityError, match=r"at least 4096 needed \(a 64-bit id needs 1024: --id\)"
    ):
        embed_asset(small, key="k", distances=False)


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"ident": b"VENDOR_A", "idents": {"nut": b"VENDOR_B"}}, MeshError, "no mesh named 'nut'"),
        ({"mark": np.ones((8, 8)), "ident": b"VENDOR_A"}, ValueError, "a mark or ids, not both"),
        ({"mark": np.ones((8, 8)), "idents": {"lid": b"x" * 8}}, ValueError, "not both"),
    ],
)
def test_bad_payload_requests_are_refused(small, kwargs, error, message):
    with pytest.raises(error, match=message):
        embed_asset(small, key="k", distances=False, **kwargs)


def test_reading_skips_meshes_too_small_to_carry_anything(small):
    rows = verify_asset(small, key="k", any_id=True)
    assert [(r["name"], r["detected"], r["reason"]) for r in rows] == [
        ("lid", False, "too small to carry a 256-bit payload: 4 vertices"),
        ("bolt", False, "too small to carry a 256-bit payload: 4 vertices"),
    ]
    with pytest.raises(ValueError, match="a mark or an id, not both"):
        verify_asset(small, key="k", mark=np.ones((8, 8)), any_id=True)
