"""Tests for :mod:`meshwm.apps.bench.scoring`: the row builders on tiny inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from meshwm.apps import bench
from meshwm.apps.bench.scoring import _mark_hex


def test_score_extraction():
    missing = bench.score_extraction(None, error="no grid found")
    assert missing == {
        "ber": 0.5,
        "corr2": 0.0,
        "p_value": 1.0,
        "detected": False,
        "note": "no grid found",
    }
    good = bench.score_extraction(
        {"ber": 0.0, "correlation": 1.0, "p_value": 1e-12, "hypotheses": 1}
    )
    assert good["detected"] and good["corr2"] == 1.0 and good["ber"] == 0.0
    # Bonferroni: the same p-value over many hypotheses is not significant.
    many = bench.score_extraction(
        {"ber": 0.1, "correlation": 0.8, "p_value": 1e-12, "hypotheses": 10**7}
    )
    assert not many["detected"]
    constant = bench.score_extraction(
        {"ber": 0.36, "correlation": float("nan"), "p_value": 1.0, "hypotheses": 1}
    )
    assert constant["corr2"] == 0.0 and "constant" in constant["note"]


def test_match_step_converges_and_reports():
    calls = []

    def embed_at(step):  # PSNR falls 20 dB per decade of step, plus a small wobble
        step = 0.006 if step is None else step  # the profile's default
        calls.append(step)
        return 60.0 - 20 * math.log10(step) + 0.3 * math.sin(step * 1e4), step

    r = bench.match_step(embed_at, 92.45)
    assert r["converged"] and abs(r["psnr"] - 92.45) < 0.05
    assert calls[0] == 0.006 and r["step"] == calls[-1] and r["iterations"] == len(calls) <= 4
    # Already there: one embedding.
    r = bench.match_step(lambda s: (80.0, s), 80.02, 0.01)
    assert r == {"step": 0.01, "psnr": 80.0, "iterations": 1, "converged": True}
    # A default calibrated per mesh: scaled from the step the embedding reports.
    r = bench.match_step(lambda s: (50.0 - 20 * math.log10(s or 0.02), s or 0.02), 60.0)
    assert r["converged"] and r["step"] == pytest.approx(10**-0.5) and r["iterations"] == 2
    # Out of reach within the bounds: stops, not converged.
    r = bench.match_step(lambda s: (50.0 - 20 * math.log10(s), s), 10.0, 0.5)
    assert not r["converged"] and r["step"] == 1.0


def test_psnr_needed():
    pts = [(92.0, 0.1), (75.0, 0.3), (60.0, 0.9), (45.0, 1.0)]
    r = bench.psnr_needed(pts, 0.6)
    assert r["psnr_needed"] == pytest.approx(67.5)
    assert "67.5 dB" in r["reason"]
    assert bench.psnr_needed(pts, 0.05)["psnr_needed"] == 92.0
    r = bench.psnr_needed(pts[:2], 0.6)
    assert r["psnr_needed"] is None
    assert "not reached" in r["reason"] and "best corr2 0.300 at 75.0 dB" in r["reason"]
    assert bench.psnr_needed([], 0.5)["psnr_needed"] is None


def test_attacked_psnr_over_grid_samples():
    ref = np.zeros((5, 3))
    ref[:, 0] = np.arange(5)
    attacked = ref.copy()
    attacked[4] += 100.0  # not a grid sample: ignored
    index = np.array([[0, 1], [2, 3]])
    assert bench.attacked_psnr(ref, index, attacked) == math.inf
    attacked[0, 0] += 0.03
    expected = 20 * math.log10(3 / math.sqrt(0.03**2 / 12))
    assert bench.attacked_psnr(ref, index, attacked) == pytest.approx(expected)


def test_mark_hex_round_trip():
    mark = (np.arange(1024).reshape(32, 32) % 7 == 0).astype(np.uint8)
    assert np.array_equal(bench.mark_from_hex(_mark_hex(mark)), mark)


def test_judge_and_summarise_paper_rows(bench_result):
    result = bench_result()
    rows = result["paper_table"]["rows"]
    lost = [r for r in rows if r["won"] is False]
    assert {r["row"] for r in lost} == {"gaussian_smoothing_hsize7_sigma10", "cropping_9pct"}
    gauss = next(r for r in lost if r["row"].startswith("gaussian"))
    # The paper's 0.3585 lies between the curve's 0.2 (74.78 dB) and 0.5 (55 dB).
    assert 55 < gauss["psnr_needed"] < 74.78
    assert all(r["won"] is None for r in rows if r["paper_corr"] is None)
    summary = result["paper_table"]["summary"]["paper"]
    assert summary["model1"]["rows"] == 10 and summary["model1"]["won"] == 8
    assert summary["model1"]["psnr_matched"]


def test_summarise_mesh_attacks(bench_result):
    s = bench.summarise_mesh_attacks(
        bench_result()["mesh_attacks"]["rows"], bench_result()["mesh_attacks"]["distortion"]
    )["paper"]
    n_required = sum(a.required for a in bench.MESH_ATTACKS)
    assert s["required"] == n_required and s["passed"] == n_required - 1
    assert s["failed"] == ["spot: crop 10 % (corr2 0.0)"] and s["mrms_ok"]
