"""Tests for :mod:`meshwm.apps.bench.report`: the Markdown tables and the files written."""

from __future__ import annotations

import json

import pytest

from meshwm.apps import bench


def test_markdown(bench_result):
    result = bench_result(("paper", "robust"))
    md = bench.paper_table_markdown(result)
    assert "| Extracted watermark without any attack | 1.000000 | 92.45 |" in md
    assert md.count("## Table ") == 3 and "invariant (no figure)" in md
    assert "Rows not won" in md and "Gaussian smoothing hsize=7, sigma=10" in md
    assert "| Random noise 0.1 " in md and "86.69" in md
    assert "meshwm bench --quick --out x" in md
    md = bench.mesh_attacks_markdown(result)
    assert "**no grid ✗**" in md and "| spot | paper | 0.006 | 73.40 |" in md


def test_write_outputs(bench_result, tmp_path):
    result = bench_result(("paper", "robust"))
    written = bench.write_outputs(result, tmp_path / "out")
    assert [p.name for p in written] == list(bench.BENCH_FILES)
    again = json.loads((tmp_path / "out" / "bench.json").read_text())
    assert again["paper_table"]["rows"] == result["paper_table"]["rows"]
    with pytest.raises(ValueError, match="would overwrite"):
        bench.write_outputs(result, tmp_path / "out")
    bench.write_outputs(result, tmp_path / "out", force=True)
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]


def test_check_out(tmp_path):
    bench.check_out(tmp_path / "new")  # a new folder in an existing one
    with pytest.raises(ValueError, match="does not exist"):
        bench.check_out(tmp_path / "no" / "such")
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="not a folder"):
        bench.check_out(tmp_path / "file")
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "curves.png").write_bytes(b"x")
    with pytest.raises(ValueError, match=r"curves\.png; use --force"):
        bench.check_out(tmp_path / "old")
    bench.check_out(tmp_path / "old", force=True)
