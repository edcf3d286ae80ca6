"""Shared by the tests of :mod:`meshwm.apps.bench`: a synthetic run result, no embedding."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from meshwm.apps import bench
from meshwm.apps.bench.scoring import _mark_hex


def _paper_rows(profile: str, corr: dict[str, float]) -> tuple[list[dict], list[dict]]:
    """Synthetic paper-table rows and runs of one model (spot) and profile."""
    runs, rows = [], []
    for paper_model, table, _ in bench.PAPER_MODELS:
        target = bench.paper_psnr(paper_model)
        runs.append(
            {
                "model": "spot",
                "profile": profile,
                "paper_model": paper_model,
                "paper_table": table,
                "target_psnr": target,
                "step": 0.001,
                "psnr": target,
                "iterations": 2,
                "converged": True,
                "seconds": 0.1,
            }
        )
        for attack in bench.PAPER_ATTACKS:
            paper = bench.PAPER_TABLES[paper_model].get(attack.key)
            c = corr.get(attack.key, 1.0)
            rows.append(
                {
                    "model": "spot",
                    "paper_model": paper_model,
                    "paper_table": table,
                    "profile": profile,
                    "row": attack.key,
                    "attack": attack.title,
                    "name": attack.name,
                    "params": attack.params,
                    "seed": attack.seed,
                    "paper_corr": None if paper is None else paper["corr"],
                    "paper_psnr": None if paper is None else paper["psnr"],
                    "step": 0.001,
                    "psnr": target,
                    "psnr_embed": target,
                    "psnr_attacked": 30.0 if attack.key == "random_noise_0.1" else target,
                    "ber": 0.0,
                    "corr2": c,
                    "p_value": 1e-300,
                    "detected": True,
                    "note": "",
                    "error": None,
                    "mark": None if c == 0 else _mark_hex(np.eye(32, dtype=np.uint8)),
                }
            )
    return runs, rows


def _result(profiles=("paper",)) -> dict:
    runs, rows, curve, distortion, mesh_rows = [], [], [], [], []
    for profile in profiles:
        r, p = _paper_rows(profile, {"gaussian_smoothing_hsize7_sigma10": 0.1, "cropping_9pct": 0})
        runs += r
        rows += p
        for key in bench.CURVE_ATTACKS:
            for psnr, c in ((92.45, 0.1), (74.78, 0.2), (55.0, 0.5)):
                curve.append(
                    {
                        "model": "spot",
                        "profile": profile,
                        "row": key,
                        "step": 0.01,
                        "psnr": psnr,
                        "corr2": c,
                        "matched": None,
                    }
                )
        distortion.append(
            {
                "mesh": "spot",
                "profile": profile,
                "n": 256,
                "step": 0.006,
                "vertices_in": 10,
                "psnr": 73.4,
                "mrms_rel": 0.00017,
                "hausdorff_rel": 0.0049,
                "rms_rel": 0.00024,
                "mark_hausdorff_rel": 0.001,
                "mrms_ok": True,
                "carriers": 1,
                "note": "",
                "seconds": 1.0,
            }
        )
        for attack in bench.MESH_ATTACKS:
            corr2 = 0.0 if attack.key == "crop_10" else 1.0
            mesh_rows.append(
                {
                    "mesh": "spot",
                    "profile": profile,
                    "row": attack.key,
                    "attack": attack.title,
                    "name": attack.name,
                    "params": attack.params,
                    "seed": attack.seed,
                    "required": attack.required,
                    "ber": 0.5 if corr2 == 0 else 0.0,
                    "corr2": corr2,
                    "p_value": 1.0,
                    "detected": corr2 > 0,
                    "note": "no grid found" if corr2 == 0 else "",
                    "error": None,
                    "pass": corr2 >= 0.9 if attack.required else None,
                    "seconds": 0.1,
                }
            )
    bench.judge_paper_rows(rows, curve)
    return {
        "meshwm_bench": 1,
        "command": "meshwm bench --quick --out x",
        "settings": {
            "quick": True,
            "key": bench.KEY,
            "n": 256,
            "profiles": list(profiles),
            "profiles_run": list(profiles),
            "profiles_skipped": {"robust": "not implemented"},
            "default_profile": "paper",
        },
        "machine": {"cpu_count": 2, "processor": "cpu", "python": "3", "versions": {"meshwm": "0"}},
        "paper_table": {
            "paper": bench.PAPER_TABLES,
            "runs": runs,
            "rows": rows,
            "summary": bench.summarise_paper(rows, runs),
        },
        "curves": {"attacks": list(bench.CURVE_ATTACKS), "points": curve},
        "mesh_attacks": {
            "attacks": [a.key for a in bench.MESH_ATTACKS],
            "distortion": distortion,
            "rows": mesh_rows,
            "summary": bench.summarise_mesh_attacks(mesh_rows, distortion),
        },
        "seconds": {"total": 1.0},
    }


@pytest.fixture
def bench_result() -> Callable[..., dict]:
    """``bench_result(profiles=("paper",))``: a whole result of one model (spot) per profile,
    with two paper rows lost (Gaussian hsize=7 and cropping 9 %) and one required mesh attack
    failed (crop 10 %)."""
    return _result
