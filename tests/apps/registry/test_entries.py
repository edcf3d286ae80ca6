"""Tests for :mod:`meshwm.apps.registry.entries`: what an entry accepts, and that params never
hold a key."""

from __future__ import annotations

import numpy as np
import pytest
from _fixtures_registry import make_asset, make_copy

from meshwm.apps.registry import AssetEntry, CopyEntry
from meshwm.apps.registry.entries import (
    decode_descriptor,
    decode_params,
    encode_descriptor,
    encode_params,
)

SHA = "ab" * 32


@pytest.mark.parametrize(
    "params",
    [
        {"key": "hunter2"},
        {"Secret": "x"},
        {"options": {"KEY": b"x"}},
        {"runs": [{"n": 1}, {"secret": 1}]},
    ],
)
def test_params_with_a_key_are_refused(params):
    with pytest.raises(ValueError, match="never stores a key or secret"):
        encode_params(params)
    with pytest.raises(ValueError, match="never stores a key or secret"):
        CopyEntry("0" * 16, None, "out.ply", SHA, 64, params)


@pytest.mark.parametrize(
    ("params", "error"),
    [({"a": float("nan")}, ValueError), ({"a": object()}, ValueError), ([1], TypeError)],
)
def test_params_must_be_a_json_object(params, error):
    with pytest.raises(error, match="params"):
        encode_params(params)


def test_params_round_trip():
    params = {"profile": "robust", "key_file_given": True, "sizes": [64, 128], "nested": {"a": 1}}
    assert decode_params(encode_params(params)) == params


def test_descriptor_round_trip_is_exact():
    rng = np.random.default_rng(3)
    descriptor = rng.normal(size=17) * 1e300
    back = decode_descriptor(encode_descriptor(descriptor))
    assert back.tobytes() == descriptor.tobytes() and back.flags.writeable


def test_entries_are_normalised_and_frozen():
    copy = CopyEntry("MARK:" + "AB" * 32, "studio", "out.ply", SHA.upper(), 256)
    assert copy.payload == "mark:" + SHA and copy.output_sha256 == SHA and copy.params == {}
    asset = make_asset(1)
    assert not asset.descriptor.flags.writeable
    with pytest.raises(AttributeError):
        asset.name = "other"  # type: ignore[misc]
    assert make_copy(1).payload == "0000000000000001"


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"payload": "0x0011223344556677"}, ValueError, "payload must be"),
        ({"payload": "mark:abc"}, ValueError, "payload must be"),
        ({"payload": 5}, TypeError, "payload must be a str"),
        ({"output_sha256": "abc"}, ValueError, "output_sha256 must be 64 hex digits"),
        ({"n": 0}, ValueError, "n must be >= 1"),
        ({"n": True}, TypeError, "n must be an int"),
        ({"output_name": ""}, ValueError, "output_name must be non-empty"),
        ({"recipient": 3}, TypeError, "recipient must be a str"),
    ],
)
def test_bad_copy_entries(change, error, match):
    fields = {"payload": "0" * 16, "recipient": None, "output_name": "o.ply"}
    fields |= {"output_sha256": SHA, "n": 64} | change
    with pytest.raises(error, match=match):
        CopyEntry(**fields)


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"input_sha256": "xyz"}, ValueError, "input_sha256 must be 64 hex digits"),
        ({"vertices": -1}, ValueError, "vertices must be >= 0"),
        ({"descriptor": np.ones((2, 2))}, ValueError, "non-empty 1-D"),
        ({"descriptor": np.array([1.0, np.nan])}, ValueError, "finite"),
        ({"references": {-1: b"x"}}, ValueError, "reference n must be >= 0"),
        ({"references": {64: "text"}}, TypeError, "references.64. must be bytes"),
    ],
)
def test_bad_asset_entries(change, error, match):
    fields = {"name": "a.ply", "input_sha256": SHA, "vertices": 3, "faces": 1}
    fields |= {"descriptor": np.ones(4), "references": {}} | change
    with pytest.raises(error, match=match):
        AssetEntry(**fields)
