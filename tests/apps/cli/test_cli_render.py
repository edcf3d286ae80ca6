"""Tests for :mod:`meshwm.apps.cli.render`; the command runs in tests/apps/test_render.py."""

from __future__ import annotations

from meshwm.apps import render as library
from meshwm.apps.cli import render


def test_the_parser_limits_are_the_library_limits():
    """The parser states them itself, so that ``render --help`` does not load matplotlib."""
    assert render.VIEWS_RANGE == library.VIEWS_RANGE
    assert render.WIDTH_RANGE == library.SIZE_RANGE
