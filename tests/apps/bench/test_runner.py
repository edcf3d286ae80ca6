"""Tests for :mod:`meshwm.apps.bench.runner` and ``meshwm bench``: the meshes, one quick run end
to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from meshwm.apps import bench
from meshwm.apps.cli import main

REPO = Path(__file__).resolve().parents[3]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    err = capsys.readouterr().err
    assert err.startswith("meshwm: error: ") and err.count("\n") == 1, err
    return err


def test_bundled_models_are_the_assets_of_a_checkout():
    assert bench.bundled_models() == [
        (name, REPO / "assets" / f"{name}.ply") for name in ("spot", "kitten", "plane_holes")
    ]
    assert bench.packaged_spot().is_file()


def test_meshes_in(tmp_path):
    with pytest.raises(ValueError, match="no mesh files"):
        bench.meshes_in(tmp_path)
    for name in ("b.ply", "a.OBJ", "notes.txt"):
        (tmp_path / name).write_text("")
    assert [n for n, _ in bench.meshes_in(tmp_path)] == ["a", "b"]


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
    assert result["seconds"]["total"] > 0  # speed lives in scripts/, not in a timed test
