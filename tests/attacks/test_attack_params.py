"""Tests for :mod:`meshwm.attacks.params`: the option table, its checks and the CLI parsing."""

from __future__ import annotations

import inspect

import pytest

from meshwm.attacks import ATTACK_PARAMS, ATTACKS, AttackParam, apply_attack

# --- the parameter registry ------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_params_describe_the_signature(name):
    """ATTACK_PARAMS lists exactly the keyword options of each attack, with its defaults."""
    signature = inspect.signature(ATTACKS[name])
    options = {
        p.name: p.default
        for p in signature.parameters.values()
        if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name != "seed"
    }
    assert signature.parameters["seed"].default == 0
    spec = ATTACK_PARAMS[name]
    assert [p.name for p in spec] == list(options)
    for p in spec:
        assert p.default == options[p.name]
        assert p.meaning
        if p.default is not None:
            assert p.check(p.default, name) == p.default


BAD_VALUES = [
    ("similarity", {"scale": 0.0}, r"scale must be a number > 0"),
    ("scaling", {"factor": 0.0}, r"factor must be a number > 0, got 0\.0"),
    ("scaling", {"factor": float("inf")}, r"factor must be a number > 0"),
    ("noise", {"amplitude": 2.0}, r"amplitude must be a number in \(0, 1\]"),
    ("round_trip", {"suffix": ".fbx"}, r"suffix must be one of \.glb, \.obj, \.off, \.ply, \.stl"),
    ("laplacian", {"lam": 0.0}, r"lam must be a number in \(0, 1\], got 0\.0"),
    ("laplacian", {"iterations": 0}, r"iterations must be an integer in 1\.\.1000"),
    ("meshlab_laplacian", {"iterations": 1001}, r"iterations must be an integer in 1\.\.1000"),
    ("taubin", {"mu": 0.0}, r"mu must be a number in \[-1, 0\)"),
    ("quantize", {"bits": 6}, r"bits must be an integer in 7\.\.16, got 6"),
    ("quantize", {"bits": 17}, r"bits must be an integer in 7\.\.16"),
    ("crop", {"fraction": 1.0}, r"fraction must be a number in \(0, 1\)"),
    ("simplify", {"keep_fraction": 0.0}, r"keep_fraction must be a number in \(0, 1\)"),
    ("subdivide_loop", {"iterations": 4}, r"iterations must be an integer in 1\.\.3"),
    ("gim_gaussian", {"hsize": 4}, r"hsize must be an odd integer in 3\.\.31, got 4"),
    ("gim_gaussian", {"sigma": -1.0}, r"sigma must be a number in \(0, 100\]"),
    ("gim_log", {"sigma": float("nan")}, r"sigma must be a number in \(0, 10\]"),
    ("gim_laplacian", {"alpha": 1.5}, r"alpha must be a number in \[0, 1\]"),
    ("gim_salt_pepper", {"density": 0.0}, r"density must be a number in \(0, 1\]"),
    ("gim_noise", {"amplitude": float("inf")}, r"amplitude must be a number in \(0, 1\]"),
    ("gim_crop", {"fraction": 0.0}, r"fraction must be a number in \(0, 1\)"),
]


@pytest.mark.parametrize(
    ("name", "options", "match"), BAD_VALUES, ids=[f"{n}-{o}" for n, o, _ in BAD_VALUES]
)
def test_bad_parameter_value_raises(mesh, name, options, match):
    """The value is checked before the mesh is looked at (gim attacks on spot included)."""
    with pytest.raises(ValueError, match=f"^{name}: {match}"):
        apply_attack(name, *mesh, **options)
    with pytest.raises(ValueError, match=match):
        ATTACKS[name](*mesh, **options)


@pytest.mark.parametrize(
    ("name", "options"),
    [("quantize", {"bits": 9.0}), ("laplacian", {"iterations": True}), ("crop", {"fraction": "1"})],
)
def test_wrong_parameter_type_raises(mesh, name, options):
    with pytest.raises(TypeError, match=f"{name}: {next(iter(options))} must be"):
        apply_attack(name, *mesh, **options)


def test_unknown_option_lists_the_valid_ones(mesh):
    with pytest.raises(ValueError, match=r"laplacian: unknown option 'bits'; valid: seed, lam, "):
        apply_attack("laplacian", *mesh, bits=9)


def test_param_parses_command_line_text():
    bits = ATTACK_PARAMS["quantize"][0]
    assert bits.parse("10", "quantize") == 10
    with pytest.raises(
        ValueError, match=r"quantize: bits must be an integer in 7\.\.16, got '9\.5'"
    ):
        bits.parse("9.5", "quantize")
    assert ATTACK_PARAMS["taubin"][1].parse("-0.6", "taubin") == -0.6
    assert AttackParam("x", float, 1.0, "m", low=0).allowed == "a number >= 0"
