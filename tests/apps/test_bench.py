"""Tests for :mod:`meshwm.apps.bench`: the row builders on tiny inputs, one quick run end to end."""

from __future__ import annotations

import io
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from meshwm.apps import bench
from meshwm.apps.cli import main
from meshwm.attacks import ATTACK_PARAMS, ATTACKS

REPO = Path(__file__).resolve().parent.parent.parent
SEED_TABLES = REPO.parent / "shared" / "seed" / "paper_tables.json"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    err = capsys.readouterr().err
    assert err.startswith("meshwm: error: ") and err.count("\n") == 1, err
    return err


# --------------------------------------------------------------------------------------------
# The row definitions


@pytest.mark.skipif(not SEED_TABLES.is_file(), reason="the paper's JSON is not next to the repo")
def test_paper_tables_are_the_seed_json():
    assert json.loads(SEED_TABLES.read_text())["models"] == bench.PAPER_TABLES


def test_every_paper_row_maps_to_a_checked_attack():
    by_key = {a.key: a for a in bench.PAPER_ATTACKS}
    for model, rows in bench.PAPER_TABLES.items():
        assert model in {m for m, _, _ in bench.PAPER_MODELS}
        assert set(rows) <= set(by_key), set(rows) - set(by_key)
    for attack in bench.PAPER_ATTACKS:
        if attack.name is None:
            assert attack.key == "none"
        elif attack.name in bench.TRANSFORMS:
            assert attack.key not in bench.PAPER_TABLES["model1"]  # no figure in the JSON
        else:
            assert attack.name.startswith("gim_"), attack
            spec = {p.name: p for p in ATTACK_PARAMS[attack.name]}
            for name, value in attack.params.items():
                assert spec[name].check(value, attack.name) == value
    # The paper's section 5 transformations are rows too.
    assert {"rotation", "translation", "scaling"} <= set(by_key)
    assert set(bench.CURVE_ATTACKS) == set(bench.PAPER_TABLES["model1"]) - {"none"}
    assert "none" in bench.QUICK_PAPER_ATTACKS and set(bench.QUICK_PAPER_ATTACKS) <= set(by_key)


def test_mesh_attacks_cover_the_issue():
    required = {a.key for a in bench.MESH_ATTACKS if a.required}
    assert {
        "none",
        "noise_0.05",
        "noise_0.1",
        "noise_0.3",
        "laplacian_5",
        "laplacian_10",
        "laplacian_30",
        "meshlab_laplacian_3",
        "quantize_11",
        "quantize_10",
        "quantize_9",
        "quantize_8",
        "crop_10",
        "crop_30",
        "similarity",
        "reorder",
        "round_trip_obj",
        "round_trip_ply",
        "round_trip_stl",
    } <= required
    beyond = {a.key for a in bench.MESH_ATTACKS if not a.required}
    assert {
        "noise_0.5",
        "laplacian_50",
        "crop_50",
        "simplify_70",
        "simplify_50",
        "simplify_10",
        "subdivide_midpoint",
        "subdivide_loop",
    } <= beyond
    keys = [a.key for a in bench.MESH_ATTACKS]
    assert len(keys) == len(set(keys))
    assert set(bench.QUICK_MESH_ATTACKS) <= set(keys)
    for attack in bench.MESH_ATTACKS:
        if attack.name is None:
            continue
        assert attack.name in ATTACKS
        spec = {p.name: p for p in ATTACK_PARAMS[attack.name]}
        for name, value in attack.params.items():
            assert spec[name].check(value, attack.name) == value
    lam = [a.params["lam"] for a in bench.MESH_ATTACKS if a.name == "laplacian"]
    assert lam and set(lam) == {0.1}


def test_attack_seeds_are_fixed_by_the_row_id():
    a = bench.Attack("noise_0.1", "noise", "0.1 %", "noise", {"amplitude": 0.001})
    b = a._replace(label="another label")
    assert a.seed == b.seed == bench.Attack("noise_0.1", "", "", None, {}).seed
    assert a.seed != bench.Attack("noise_0.3", "", "", None, {}).seed


def test_transforms_are_rigid_translations_and_scalings():
    rng = np.random.default_rng(0)
    v = rng.normal(size=(20, 3))
    f = np.array([[0, 1, 2]])
    rv, rf = bench.TRANSFORMS["rotation"](v, f, seed=3)
    assert rf is f or np.array_equal(rf, f)
    d0 = np.linalg.norm(v[:, None] - v[None], axis=-1)
    d1 = np.linalg.norm(rv[:, None] - rv[None], axis=-1)
    assert np.allclose(d0, d1) and not np.allclose(rv, v)
    assert np.allclose(rv.mean(axis=0), v.mean(axis=0))
    tv, _ = bench.TRANSFORMS["translation"](v, f, seed=3)
    shift = tv - v
    assert np.allclose(shift, shift[0])
    diag = np.linalg.norm(np.ptp(v, axis=0))
    assert np.linalg.norm(shift[0]) == pytest.approx(10 * diag)
    sv, _ = bench.TRANSFORMS["scaling"](v, f)
    assert np.allclose(sv, 0.1 * v)
    again, _ = bench.TRANSFORMS["rotation"](v, f, seed=3)
    assert np.array_equal(again, rv)


def test_apply_bench_attack_none_returns_the_mesh():
    v, f = np.eye(3), np.array([[0, 1, 2]])
    none = next(a for a in bench.PAPER_ATTACKS if a.key == "none")
    assert bench.apply_bench_attack(none, v, f) == (v, f)


# --------------------------------------------------------------------------------------------
# Pure builders


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
    assert np.array_equal(bench.mark_from_hex(bench._mark_hex(mark)), mark)


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
                    "mark": None if c == 0 else bench._mark_hex(np.eye(32, dtype=np.uint8)),
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


def test_judge_and_summarise_paper_rows():
    result = _result()
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


def test_summarise_mesh_attacks():
    s = bench.summarise_mesh_attacks(
        _result()["mesh_attacks"]["rows"], _result()["mesh_attacks"]["distortion"]
    )["paper"]
    n_required = sum(a.required for a in bench.MESH_ATTACKS)
    assert s["required"] == n_required and s["passed"] == n_required - 1
    assert s["failed"] == ["spot: crop 10 % (corr2 0.0)"] and s["mrms_ok"]


def test_markdown_and_pictures(tmp_path):
    result = _result(("paper", "robust"))
    md = bench.paper_table_markdown(result)
    assert "| Extracted watermark without any attack | 1.000000 | 92.45 |" in md
    assert md.count("## Table ") == 3 and "invariant (no figure)" in md
    assert "Rows not won" in md and "Gaussian smoothing hsize=7, sigma=10" in md
    assert "| Random noise 0.1 " in md and "86.69" in md
    assert "meshwm bench --quick --out x" in md
    md = bench.mesh_attacks_markdown(result)
    assert "**no grid ✗**" in md and "| spot | paper | 0.006 | 73.40 |" in md
    for png in (bench.paper_marks_png(result), bench.curves_png(result)):
        assert png.startswith(PNG_SIGNATURE)
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


def test_meshes_in(tmp_path):
    with pytest.raises(ValueError, match="no mesh files"):
        bench.meshes_in(tmp_path)
    for name in ("b.ply", "a.OBJ", "notes.txt"):
        (tmp_path / name).write_text("")
    assert [n for n, _ in bench.meshes_in(tmp_path)] == ["a", "b"]


def test_progress_bar():
    stream = io.StringIO()
    bar = bench.ProgressBar(stream, width=10)
    bar(0, 4, "starting")
    bar(1, 4, "first")  # throttled: within 0.1 s of the last draw
    bar(4, 4, "done")
    text = stream.getvalue()
    assert text.startswith("\r  0% [..........] 0/4") and text.endswith("\n")
    assert "100% [##########] 4/4" in text and "first" not in text


# --------------------------------------------------------------------------------------------
# Command line


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--profiles", "paper,fancy"], "--profiles"),
        (["--profiles", ","], "--profiles"),
        (["--quick", "--meshes", "."], "--quick runs the packaged spot mesh only"),
    ],
)
def test_cli_bench_refuses_bad_options(tmp_path, capsys, argv, message):
    code = main(["bench", "--out", str(tmp_path / "out"), *argv])
    assert code == 2
    assert message in _one_line_error(capsys)
    assert not (tmp_path / "out").exists()


def test_cli_bench_refuses_to_overwrite_before_any_work(tmp_path, capsys):
    (tmp_path / "bench.json").write_text("{}")
    assert main(["bench", "--quick", "--out", str(tmp_path)]) == 2
    assert "would overwrite bench.json; use --force" in _one_line_error(capsys)
    assert (tmp_path / "bench.json").read_text() == "{}"


@pytest.mark.slow
def test_quick_bench_end_to_end(tmp_path):
    out = tmp_path / "bench"
    proc = subprocess.run(
        [sys.executable, "-m", "meshwm", "bench", "--quick", "--out", str(out), "--json"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # no progress bar when stderr is not a terminal
    summary = json.loads(proc.stdout)
    assert summary["files"] == sorted(bench.BENCH_FILES)
    for name in ("paper_marks.png", "curves.png"):
        assert (out / name).read_bytes().startswith(PNG_SIGNATURE)
    result = json.loads((out / "bench.json").read_text())
    assert set(result) >= {
        "command",
        "settings",
        "machine",
        "paper_table",
        "curves",
        "mesh_attacks",
        "seconds",
    }
    assert result["command"].startswith("meshwm bench --quick")
    profiles = result["settings"]["profiles_run"]
    assert "paper" in profiles
    assert set(profiles) | set(result["settings"]["profiles_skipped"]) == {"paper", "robust"}
    pt = json.loads((out / "paper_table.json").read_text())
    assert pt["rows"] == result["paper_table"]["rows"]
    for run in pt["runs"]:
        assert run["converged"]
        assert abs(run["psnr"] - run["target_psnr"]) < 0.05
    targets = {round(r["target_psnr"], 2) for r in pt["runs"]}
    assert targets == {92.45, 74.78, 90.2}
    ma = json.loads((out / "mesh_attacks.json").read_text())
    for profile in profiles:
        assert len([r for r in pt["runs"] if r["profile"] == profile]) == 3
        for row in pt["rows"]:
            if row["profile"] == profile and row["row"] == "none":
                assert (row["corr2"], row["ber"], row["detected"]) == (1.0, 0.0, True)
        none = [r for r in ma["rows"] if r["profile"] == profile and r["row"] == "none"]
        assert len(none) == 1 and (none[0]["corr2"], none[0]["ber"]) == (1.0, 0.0)
        assert none[0]["detected"]
        assert {r["row"] for r in ma["rows"] if r["profile"] == profile} == set(
            bench.QUICK_MESH_ATTACKS
        )
        assert {r["row"] for r in pt["rows"] if r["profile"] == profile} == set(
            bench.QUICK_PAPER_ATTACKS
        )
        curve = {p["psnr"] for p in result["curves"]["points"] if p["profile"] == profile}
        assert len(curve) >= 4
    assert result["seconds"]["total"] < 180
