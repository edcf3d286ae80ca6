"""Tests for :mod:`meshwm.apps.cli.options`: the option types and the help they give."""

from __future__ import annotations

import argparse

import pytest

from meshwm._validate import DEFAULT_MAX_FACES, DEFAULT_SIZE, SIZE_RANGE
from meshwm.apps.cli import build_parser, options
from meshwm.message.mark import MARK_SIZE_RANGE


@pytest.mark.parametrize(
    ("parse", "text", "value"),
    [
        (options.integer, "-7", -7),
        (options.positive_int, "1", 1),
        (options.seed, "0", 0),
        (options.grid_size, str(SIZE_RANGE[0]), SIZE_RANGE[0]),
        (options.grid_size, str(SIZE_RANGE[1]), SIZE_RANGE[1]),
        (options.mark_size, str(MARK_SIZE_RANGE[0]), MARK_SIZE_RANGE[0]),
        (options.mark_size, str(MARK_SIZE_RANGE[1]), MARK_SIZE_RANGE[1]),
        (options.bounded("a width", 2, 5), "5", 5),
        (options.probability, "1e-6", 1e-6),
        (options.real, "-0.5", -0.5),
        (options.names, " z, x ", ("z", "x")),
        (options.key, "k", "k"),
        (options.ident, "0xC0FFEE42", bytes.fromhex("00000000c0ffee42")),
    ],
)
def test_a_good_value_parses(parse, text, value):
    assert parse(text) == value


@pytest.mark.parametrize(
    ("parse", "text", "message"),
    [
        (options.integer, "1.5", "expected a whole number, got '1.5'"),
        (options.positive_int, "0", "expected a number >= 1, got 0"),
        (options.seed, "-1", "expected a number >= 0, got -1"),
        (options.grid_size, "abc", "expected a whole number, got 'abc'"),
        (
            options.grid_size,
            "100",
            f"the size must be a power of two between {SIZE_RANGE[0]} and {SIZE_RANGE[1]}, got 100",
        ),
        (options.grid_size, str(2 * SIZE_RANGE[1]), "power of two"),
        (options.grid_size, str(SIZE_RANGE[0] // 2), "power of two"),
        (options.grid_size, "0", "power of two"),
        (
            options.mark_size,
            str(MARK_SIZE_RANGE[0] - 1),
            f"expected a mark size in {MARK_SIZE_RANGE[0]}..{MARK_SIZE_RANGE[1]}",
        ),
        (options.mark_size, str(MARK_SIZE_RANGE[1] + 1), "expected a mark size in"),
        (options.bounded("a width", 2, 5), "6", "expected a width in 2..5, got 6"),
        (options.probability, "1", "expected a probability in (0, 1), got 1"),
        (options.probability, "nan", "expected a probability in (0, 1)"),
        (options.probability, "x", "expected a number, got 'x'"),
        (options.real, "inf", "expected a finite number, got inf"),
        (options.real, "nan", "expected a finite number, got nan"),
        (options.names, ",", "expected a comma-separated list of names"),
        (options.key, "", "the key must not be empty"),
        (options.ident, "z" * 9, "at most 8 bytes"),
    ],
)
def test_a_bad_value_is_an_argument_type_error(parse, text, message):
    with pytest.raises(argparse.ArgumentTypeError) as exc:
        parse(text)
    assert message in str(exc.value)


def _help(capsys: pytest.CaptureFixture, command: str) -> str:
    with pytest.raises(SystemExit):
        build_parser([command]).parse_args([command, "--help"])
    return " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("command", ["remesh", "embed"])
def test_size_help_states_the_library_range_and_default(command, capsys):
    low, high = SIZE_RANGE
    assert f"a power of two {low}..{high} ({DEFAULT_SIZE})" in _help(capsys, command)


@pytest.mark.parametrize("command", ["remesh", "embed", "extract", "verify"])
def test_max_faces_help_states_the_library_default(command, capsys):
    assert f"refuse inputs with more faces ({DEFAULT_MAX_FACES})" in _help(capsys, command)


@pytest.mark.parametrize("command", ["embed", "extract", "verify"])
def test_watermark_options_default_to_the_library_parameters(command):
    from meshwm.params import WatermarkParams

    argv = [command, "in.ply", "--key", "k"]
    argv += {"embed": ["-o", "out.ply"], "verify": ["--any-id"]}.get(command, [])
    args = build_parser([command]).parse_args(argv)
    params = options.watermark_params(args)
    assert params == WatermarkParams()
    assert args.max_faces == DEFAULT_MAX_FACES
    assert args.mark_size == options.DEFAULT_MARK_SIZE


def test_profile_options_come_from_the_registry_and_belong_to_their_profile():
    from meshwm.params import WatermarkParams
    from meshwm.profiles.paper import PaperOptions
    from meshwm.profiles.robust import RobustOptions

    parser = build_parser(["embed"])
    base = ["embed", "in.ply", "-o", "out.ply", "--key", "k"]
    paper = parser.parse_args([*base, "--profile", "paper", "--step", "0.01", "--channels", "z,x"])
    assert options.watermark_params(paper) == WatermarkParams(
        profile="paper", options=PaperOptions(step=0.01, channels=("x", "z"))
    )
    robust = parser.parse_args([*base, "--tangential-step", "0.05"])
    assert options.watermark_params(robust).options == RobustOptions(tangential_step=0.05)
    with pytest.raises(
        ValueError,
        match="--step is an option of the 'paper' profile; the "
        "'robust' profile takes --tangential-step, --distortion",
    ):
        options.watermark_params(parser.parse_args([*base, "--step", "0.01"]))
    with pytest.raises(ValueError, match="unknown channels"):
        options.watermark_params(
            parser.parse_args([*base, "--profile", "paper", "--channels", "w"])
        )
