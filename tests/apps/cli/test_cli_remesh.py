"""Tests for :mod:`meshwm.apps.cli.remesh`, run in-process through ``main(argv)``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import trimesh
from _malformed import CASE_IDS, make_malformed_cases

from meshwm.apps.cli import main
from meshwm.mesh.io import read_mesh

ASSETS = Path(__file__).parents[3] / "assets"


@pytest.fixture(scope="module")
def malformed(tmp_path_factory: pytest.TempPathFactory) -> dict:
    cases = make_malformed_cases(tmp_path_factory.mktemp("malformed_cli"))
    return {case.case_id: case.path for case in cases}


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    err = capsys.readouterr().err
    assert err.endswith("\n")
    assert err.count("\n") == 1, err
    assert err.startswith("meshwm: ")
    assert "Traceback" not in err
    return err


def test_remesh_json_report(tmp_path, capsys):
    out = tmp_path / "spot_gim.ply"
    code = main(["remesh", str(ASSETS / "spot.ply"), "-o", str(out), "--size", "128", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    v, f = read_mesh(out)
    assert (report["vertices_out"], report["faces_out"]) == (len(v), len(f))
    assert (report["vertices_in"], report["faces_in"]) == (2930, 5856)
    assert report["n"] == 128
    assert report["flipped_triangles"] == 0
    assert 0 < report["hausdorff_rel"] <= 0.02
    assert 0 < report["rms_rel"] <= report["hausdorff_rel"]
    assert report["seconds"] > 0
    assert trimesh.Trimesh(v, f, process=False).is_watertight


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply"])
def test_remesh_writes_every_format(tmp_path, capsys, suffix):
    out = tmp_path / f"out{suffix}"
    code = main(["remesh", str(ASSETS / "kitten.ply"), "-o", str(out), "--size", "64"])
    assert code == 0
    assert "Hausdorff" in capsys.readouterr().out
    v, f = read_mesh(out)
    assert len(f) > 0 and len(v) > 0


def test_remesh_same_input_same_bytes(tmp_path):
    outs = [tmp_path / "a.ply", tmp_path / "b.ply"]
    for out in outs:
        main(["remesh", str(ASSETS / "spot.ply"), "-o", str(out), "--size", "64", "--no-distance"])
    assert outs[0].read_bytes() == outs[1].read_bytes()


def test_remesh_never_overwrites_its_input_without_force(tmp_path, capsys):
    src = tmp_path / "spot.ply"
    shutil.copy(ASSETS / "spot.ply", src)
    before = src.read_bytes()
    code = main(["remesh", str(src), "-o", str(src), "--size", "64"])
    assert code == 2
    assert "--force" in _one_line_error(capsys)
    assert src.read_bytes() == before
    assert main(["remesh", str(src), "-o", str(src), "--size", "64", "--force"]) == 0
    assert src.read_bytes() != before


@pytest.mark.parametrize("case_id", CASE_IDS)
def test_malformed_input_exits_2_with_one_line_and_no_output(case_id, malformed, tmp_path, capsys):
    out = tmp_path / "out.ply"
    code = main(["remesh", str(malformed[case_id]), "-o", str(out), "--size", "64"])
    assert code == 2
    _one_line_error(capsys)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_missing_input_exits_2(tmp_path, capsys):
    assert main(["remesh", str(tmp_path / "nope.ply"), "-o", str(tmp_path / "o.ply")]) == 2
    assert "nope.ply" in _one_line_error(capsys)


def test_too_many_faces_exits_2(tmp_path, capsys):
    out = tmp_path / "o.ply"
    assert main(["remesh", str(ASSETS / "spot.ply"), "-o", str(out), "--max-faces", "100"]) == 2
    assert "100" in _one_line_error(capsys)
    assert not out.exists()
