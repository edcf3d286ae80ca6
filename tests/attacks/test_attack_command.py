"""Tests of the ``meshwm attack`` command (:mod:`meshwm.apps.cli`) over the attack registry."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from numpy.testing import assert_array_equal

from meshwm.apps.cli import main
from meshwm.attacks import ATTACK_PARAMS
from meshwm.attacks.image import (
    gim_salt_pepper,
)
from meshwm.attacks.smoothing import laplacian
from meshwm.attacks.transforms import (
    crop,
)
from meshwm.mesh.io import read_mesh, write_mesh

# --- the command line ------------------------------------------------------------------------


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert err.startswith("meshwm: error: ")
    return err


@pytest.fixture(scope="module")
def gim_file(gim_mesh, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("gim") / "spot_gim64.ply"
    write_mesh(path, *gim_mesh)
    return path


SPOT = Path(__file__).parent.parent.parent / "assets" / "spot.ply"


def test_cli_attack_writes_the_attacked_mesh(tmp_path, capsys, mesh):
    out = tmp_path / "smooth.ply"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "laplacian", "--iterations", "10"]
    assert main(argv) == 0
    line = capsys.readouterr().out
    assert line.count("\n") == 1 and "laplacian(lam=0.1, iterations=10), seed 0" in line
    v, f = read_mesh(out)
    expected = laplacian(*mesh, iterations=10)
    assert_array_equal(v, expected[0])
    assert_array_equal(f, expected[1])


def test_cli_attack_json(tmp_path, capsys, mesh):
    out = tmp_path / "cropped.obj"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "crop", "--fraction", "0.3"]
    assert main([*argv, "--seed", "7", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    v, f = read_mesh(out)
    assert report["kind"] == "crop"
    assert report["params"] == {"fraction": 0.3}
    assert report["seed"] == 7
    assert (report["vertices_in"], report["faces_in"]) == (len(mesh[0]), len(mesh[1]))
    assert (report["vertices_out"], report["faces_out"]) == (len(v), len(f))
    assert report["input"] == str(SPOT) and report["output"] == str(out)
    assert_array_equal(f, crop(*mesh, seed=7, fraction=0.3)[1])


def test_cli_attack_defaults_and_option_spellings(tmp_path, capsys):
    out = tmp_path / "s.ply"
    argv = ["attack", str(SPOT), "-o", str(out), "--kind", "simplify", "--json"]
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["params"] == {"keep_fraction": 0.5}
    for flag in ("--keep-fraction", "--keep_fraction"):
        assert main([*argv, "--force", flag, "0.7"]) == 0
        assert abs(json.loads(capsys.readouterr().out)["faces_out"] / 5856 - 0.7) <= 0.02


def test_cli_gim_attack_on_a_meshwm_file(tmp_path, capsys, gim_file, gim_mesh):
    out = tmp_path / "sp.ply"
    argv = ["attack", str(gim_file), "-o", str(out), "--kind", "gim_salt_pepper"]
    assert main([*argv, "--density", "0.1", "--seed", "3"]) == 0
    v, f = read_mesh(out)
    assert_array_equal(f, gim_mesh[1])
    assert_array_equal(v, gim_salt_pepper(*gim_mesh, seed=3, density=0.1)[0])
    assert "gim_salt_pepper(density=0.1), seed 3" in capsys.readouterr().out


CLI_ERRORS = [
    (["--kind", "smooth"], "invalid choice: 'smooth'"),
    (["--kind", "laplacian", "--bits", "9"], "--kind laplacian takes no --bits; its parameters: "),
    (["--kind", "reorder", "--lam", "0.5"], "its parameters: none"),
    (["--kind", "laplacian", "--foo", "1"], "unrecognized arguments: --foo 1"),
    (["--kind", "quantize", "--bits", "5"], r"quantize: bits must be an integer in 7\.\.16, got 5"),
    (["--kind", "quantize", "--bits", "x"], r"bits must be an integer in 7\.\.16, got 'x'"),
    (["--kind", "taubin", "--mu", "0.5"], r"mu must be a number in \[-1, 0\)"),
    (["--kind", "noise", "--seed", "-1"], "expected a number >= 0"),
    (["--kind", "gim_log"], "gim attacks need a mesh written by meshwm"),
    ([], "the following arguments are required: --kind"),
]


@pytest.mark.parametrize(("extra", "match"), CLI_ERRORS, ids=[" ".join(e) for e, _ in CLI_ERRORS])
def test_cli_attack_errors_exit_2_with_one_line_and_no_output(tmp_path, capsys, extra, match):
    out = tmp_path / "out.ply"
    assert main(["attack", str(SPOT), "-o", str(out), *extra]) == 2
    assert re.search(match, _one_line_error(capsys))
    assert not out.exists()


def test_cli_attack_lists_the_valid_parameters(tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(["attack", str(SPOT), "-o", str(out), "--kind", "taubin", "--bits", "9"]) == 2
    assert "its parameters: --lam, --mu, --iterations" in _one_line_error(capsys)


def test_cli_attack_missing_input(tmp_path, capsys):
    out = tmp_path / "out.ply"
    assert main(["attack", str(tmp_path / "nope.ply"), "-o", str(out), "--kind", "noise"]) == 2
    assert "nope.ply" in _one_line_error(capsys)
    assert not out.exists()


def test_cli_attack_never_overwrites_its_input_without_force(tmp_path, capsys):
    src = tmp_path / "spot.ply"
    shutil.copy(SPOT, src)
    before = src.read_bytes()
    assert main(["attack", str(src), "-o", str(src), "--kind", "noise"]) == 2
    assert "--force" in _one_line_error(capsys)
    assert src.read_bytes() == before
    assert main(["attack", str(src), "-o", str(src), "--kind", "noise", "--force"]) == 0
    assert src.read_bytes() != before
    assert [p.name for p in tmp_path.iterdir()] == ["spot.ply"]  # no temporary file left


def test_cli_attack_help_lists_every_kind(capsys):
    with pytest.raises(SystemExit) as info:
        main(["attack", "--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    for name, params in ATTACK_PARAMS.items():
        assert f"  {name}: " in text
        for p in params:
            assert f"--{p.name}" in text
