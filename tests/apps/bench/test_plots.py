"""Tests for :mod:`meshwm.apps.bench.plots`: the two PNG figures."""

from __future__ import annotations

import pytest

from meshwm.apps import bench

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("draw", [bench.paper_marks_png, bench.curves_png])
def test_figures_are_png_and_the_same_bytes_every_time(bench_result, draw):
    result = bench_result(("paper", "robust"))
    png = draw(result)
    assert png.startswith(PNG_SIGNATURE)
    assert draw(result) == png  # no time stamp or version in the file
