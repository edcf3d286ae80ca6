"""Tests for :mod:`meshwm.params` and the profiles' options: frozen, validated parameters."""

from __future__ import annotations

import dataclasses
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from meshwm.params import WatermarkParams
from meshwm.profiles import PROFILES, get_profile, options_type
from meshwm.profiles.paper.options import CHANNELS, PaperOptions
from meshwm.profiles.robust.options import RobustOptions
from meshwm.signal.wavelet import MRR_LEVEL3_KEYS


def _paper(**options) -> WatermarkParams:
    return WatermarkParams(profile="paper", options=PaperOptions(**options))


def test_defaults_are_valid_and_documented():
    p = WatermarkParams()
    assert p.size == 256
    assert p.size & (p.size - 1) == 0
    assert p.profile == "robust"
    assert p.options == RobustOptions()
    assert p.options.tangential_step is None  # robust: calibrated per mesh to the distortion
    assert 0 < p.options.distortion < 2e-4  # under the MRMS budget of 0.02 %
    paper = WatermarkParams(profile="paper").options
    assert paper.step == 0.006
    assert paper.channels == ("x", "y")
    assert paper.bands == MRR_LEVEL3_KEYS and len(paper.bands) == 16
    assert 0 <= paper.remainder_zero < paper.remainder_one < 1
    assert paper.min_carriers >= 1
    # Re-validating the defaults changes nothing.
    assert WatermarkParams(**{f.name: getattr(p, f.name) for f in dataclasses.fields(p)}) == p


def test_every_registered_profile_has_options_and_a_profile():
    for name in PROFILES:
        assert get_profile(name).name == name
        assert get_profile(name).options_type is options_type(name)
        assert isinstance(WatermarkParams(profile=name).options, options_type(name))


def test_options_of_another_profile_are_refused():
    with pytest.raises(TypeError, match="options of the 'robust' profile must be RobustOptions"):
        WatermarkParams(options=PaperOptions())
    with pytest.raises(TypeError, match="must be PaperOptions, got RobustOptions"):
        WatermarkParams(profile="paper", options=RobustOptions())


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"distortion": 0.0}, "distortion must lie"),
        ({"distortion": 0.5}, "distortion must lie"),
        ({"distortion": "high"}, "distortion must be a number"),
        ({"tangential_step": 0.0}, "tangential_step must lie"),
        ({"tangential_step": 2.0}, "tangential_step must lie"),
        ({"tangential_step": True}, "tangential_step must be a number"),
    ],
)
def test_robust_options_are_validated(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        RobustOptions(**kw)


def test_unknown_profile_is_refused():
    with pytest.raises(ValueError, match="unknown profile 'fast'; valid: robust, paper"):
        WatermarkParams(profile="fast")


def test_dict_round_trip_through_json():
    p = WatermarkParams(
        profile="paper",
        size=128,
        arnold_iterations=0,
        options=PaperOptions(
            channels=("x", "y", "z"),
            bands=MRR_LEVEL3_KEYS[3:9],
            step=0.02,
            remainder_one=0.9,
            remainder_zero=0.1,
            min_carriers=5,
        ),
    )
    d = p.to_dict()
    assert isinstance(d["options"]["channels"], list) and isinstance(d["options"]["bands"], list)
    assert WatermarkParams.from_dict(d) == p
    assert WatermarkParams.from_dict(json.loads(json.dumps(d))) == p
    robust = WatermarkParams(options=RobustOptions(tangential_step=0.05))
    assert WatermarkParams.from_dict(json.loads(json.dumps(robust.to_dict()))) == robust


@settings(max_examples=30, deadline=None)
@given(
    size=st.sampled_from([64, 128, 256, 512, 1024, 2048]),
    channels=st.sets(st.sampled_from(CHANNELS), min_size=1),
    bands=st.sets(st.sampled_from(MRR_LEVEL3_KEYS), min_size=1),
    step=st.floats(1e-6, 1.0),
    remainders=st.tuples(st.floats(0, 0.999), st.floats(0, 0.999)).filter(lambda r: r[0] != r[1]),
    min_carriers=st.integers(1, 64),
)
def test_any_valid_parameters_round_trip(size, channels, bands, step, remainders, min_carriers):
    zero, one = sorted(remainders)
    p = WatermarkParams(
        profile="paper",
        size=size,
        options=PaperOptions(
            channels=tuple(channels),
            bands=tuple(bands),
            step=step,
            remainder_zero=zero,
            remainder_one=one,
            min_carriers=min_carriers,
        ),
    )
    assert WatermarkParams.from_dict(json.loads(json.dumps(p.to_dict()))) == p


def test_channel_and_band_order_is_canonical():
    a = _paper(channels=("z", "x"), bands=tuple(reversed(MRR_LEVEL3_KEYS[:4])))
    b = _paper(channels=("x", "z"), bands=MRR_LEVEL3_KEYS[:4])
    assert a.options.channels == ("x", "z")
    assert a.options.bands == MRR_LEVEL3_KEYS[:4]
    assert a == b and hash(a) == hash(b)


def test_single_name_string_and_lists_are_accepted():
    p = PaperOptions(channels="z", bands=list(MRR_LEVEL3_KEYS[:2]))  # type: ignore[arg-type]
    assert p.channels == ("z",)
    assert p.bands == MRR_LEVEL3_KEYS[:2]


def test_numbers_are_stored_as_float():
    p = PaperOptions(step=1, remainder_zero=0, remainder_one=1 / 2)
    assert type(p.step) is float and type(p.remainder_zero) is float


@pytest.mark.parametrize(
    ("fields", "error", "match"),
    [
        ({"size": 100}, ValueError, "power of two"),
        ({"size": 32}, ValueError, "power of two"),
        ({"size": 4096}, ValueError, "power of two"),
        ({"size": 0}, ValueError, "power of two"),
        ({"size": 128.0}, TypeError, "size must be an integer"),
        ({"size": True}, TypeError, "size must be an integer"),
        ({"arnold_iterations": True}, TypeError, "arnold_iterations must be an integer"),
        ({"arnold_iterations": -1}, ValueError, "arnold_iterations"),
        ({"min_carriers": False}, TypeError, "min_carriers must be an integer"),
        ({"min_carriers": 0}, ValueError, "min_carriers"),
        ({"min_carriers": 65}, ValueError, "min_carriers"),
        ({"step": 0}, ValueError, "step must lie"),
        ({"step": -0.01}, ValueError, "step must lie"),
        ({"step": 2.0}, ValueError, "step must lie"),
        ({"step": float("nan")}, ValueError, "step must lie"),
        ({"step": True}, TypeError, "step must be a number"),
        ({"step": "0.01"}, TypeError, "step must be a number"),
        ({"remainder_zero": 0.5, "remainder_one": 0.5}, ValueError, "remainder_zero <"),
        ({"remainder_zero": 0.75, "remainder_one": 0.25}, ValueError, "remainder_zero <"),
        ({"remainder_zero": -0.1}, ValueError, "remainder_zero <"),
        ({"remainder_one": 1.0}, ValueError, "remainder_zero <"),
        ({"remainder_zero": float("nan")}, ValueError, "remainder_zero <"),
        ({"channels": ("w",)}, ValueError, r"unknown channels \['w'\]"),
        ({"channels": ("x", "X")}, ValueError, "unknown channels"),
        ({"channels": ()}, ValueError, "channels must not be empty"),
        ({"channels": ("x", "x")}, ValueError, "channels has duplicates"),
        ({"bands": ("hhh", "nope")}, ValueError, r"unknown bands \['nope'\]"),
        ({"bands": ("a",)}, ValueError, "unknown bands"),
        ({"bands": ("hhh", "hhh")}, ValueError, "bands has duplicates"),
    ],
    ids=lambda x: repr(x) if isinstance(x, dict) else "",
)
def test_invalid_field_is_refused(fields, error, match):
    with pytest.raises(error, match=match):
        if set(fields) <= {"size", "arnold_iterations"}:
            WatermarkParams(**fields)
        else:
            PaperOptions(**fields)


def test_unknown_key_in_dict_is_refused():
    d = WatermarkParams().to_dict()
    d["key"] = "secret"
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['key'\]"):
        WatermarkParams.from_dict(d)


def test_invalid_value_in_dict_is_refused():
    d = WatermarkParams().to_dict()
    d["size"] = 100
    with pytest.raises(ValueError, match="power of two"):
        WatermarkParams.from_dict(d)


def test_partial_dict_takes_defaults():
    assert WatermarkParams.from_dict({"size": 64}) == WatermarkParams(size=64)
    partial = {"profile": "paper", "options": {"step": 0.01}}
    assert WatermarkParams.from_dict(partial) == _paper(step=0.01)


def test_unknown_option_in_dict_is_refused():
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['step'\]"):
        WatermarkParams.from_dict({"profile": "robust", "options": {"step": 0.01}})


def test_params_are_frozen():
    p = WatermarkParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.size = 128  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.options.distortion = 1e-3  # type: ignore[misc]
    assert dataclasses.replace(p, size=128).size == 128
    assert p.size == 256
