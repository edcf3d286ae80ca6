"""Tests for :mod:`meshwm.apps.cli`, run in-process through ``main(argv)``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import trimesh
from _malformed import CASE_IDS, make_malformed_cases

from meshwm.apps.cli import main
from meshwm.mesh.io import read_mesh

ASSETS = Path(__file__).parent.parent.parent / "assets"


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


@pytest.mark.parametrize(
    "argv",
    [
        ["remesh", "IN", "-o", "OUT.ply", "--size", "100"],
        ["remesh", "IN", "-o", "OUT.ply", "--size", "abc"],
        ["remesh", "IN", "-o", "OUT.ply", "--size", "1073741824"],
        ["remesh", "IN", "-o", "OUT.ply", "--max-faces", "0"],
        ["remesh", "IN"],
        ["remesh", "IN", "-o", "OUT.xyz"],
        ["frobnicate"],
        [],
        ["remesh", "IN", "-o", "OUT.ply", "--bogus"],
    ],
)
def test_bad_options_exit_2_with_one_line(argv, tmp_path, capsys):
    argv = [
        a.replace("IN", str(ASSETS / "spot.ply")).replace("OUT", str(tmp_path / "o")) for a in argv
    ]
    assert main(argv) == 2
    _one_line_error(capsys)
    assert list(tmp_path.iterdir()) == []


def test_missing_input_exits_2(tmp_path, capsys):
    assert main(["remesh", str(tmp_path / "nope.ply"), "-o", str(tmp_path / "o.ply")]) == 2
    assert "nope.ply" in _one_line_error(capsys)


def test_too_many_faces_exits_2(tmp_path, capsys):
    out = tmp_path / "o.ply"
    assert main(["remesh", str(ASSETS / "spot.ply"), "-o", str(out), "--max-faces", "100"]) == 2
    assert "100" in _one_line_error(capsys)
    assert not out.exists()


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("meshwm ")


def test_console_entry_point_in_a_subprocess(tmp_path):
    """The real process: exit code 2, one stderr line, nothing on stdout, no output file."""
    import subprocess
    import sys

    bad = tmp_path / "bad.ply"
    bad.write_bytes((ASSETS / "spot.ply").read_bytes()[:700])
    out = tmp_path / "o.ply"
    proc = subprocess.run(
        [sys.executable, "-m", "meshwm.apps.cli", "remesh", str(bad), "-o", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert not out.exists()
