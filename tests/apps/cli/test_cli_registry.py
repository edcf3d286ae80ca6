"""Tests for ``meshwm registry {list,show,remove}``, run in-process through ``main(argv)`` on
SQLite and on a throwaway PostgreSQL server (``tests/_fixtures_registry.py``)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from _fixtures_registry import make_asset, make_copy

from meshwm.apps.cli import main
from meshwm.apps.registry import Registry

TEXT_ID = b"VENDOR_A".hex()
MARK = "mark:" + "ef" * 32


@pytest.fixture
def filled(target) -> tuple[str, int, int]:
    """A registry of two assets: the first with two copies, the second with one."""
    with Registry.open(target) as registry:
        first, _ = registry.record_embed(
            make_asset(1, sizes=(0, 64, 128)), make_copy(1, payload=TEXT_ID)
        )
        registry.record_embed(make_asset(1), make_copy(2, payload=MARK, recipient=None))
        second, _ = registry.record_embed(make_asset(2), make_copy(3))
    return target, first, second


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert err.startswith("meshwm: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


def test_list(filled, capsys):
    target, first, second = filled
    assert main(["registry", "list", target]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == f"asset {first}  asset1.ply  1001 vertices  2 copies"
    assert lines[1].startswith('  copy 1  "VENDOR_A" (0x56454e444f525f41)  to vendor  20')
    assert lines[2].startswith(f"  copy 2  {MARK}  to -  20")
    assert lines[3] == f"asset {second}  asset2.ply  1002 vertices  1 copy"
    assert lines[4].startswith("  copy 3  0x0000000000000003  to vendor  ")
    assert len(lines) == 5


def test_list_json(filled, capsys):
    target, first, _ = filled
    assert main(["registry", "list", target, "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [a["copy_count"] for a in report["assets"]] == [2, 1]
    asset = report["assets"][0]
    assert asset["id"] == first and asset["input_sha256"] == make_asset(1).input_sha256
    assert [c["payload"] for c in asset["copies"]] == [TEXT_ID, MARK]
    assert asset["copies"][0]["params"] == {"index": 1, "profile": "robust", "strength": 1.0}
    assert asset["copies"][1]["recipient"] is None
    assert report["registry"] == target.replace("postgresql://", "postgresql+psycopg://")


def test_show(filled, capsys):
    target, first, _ = filled
    assert main(["registry", "show", target, str(first)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"asset {first}  asset1.ply\n")
    assert "references    probe: 1000 bytes, N=64: 1000 bytes, N=128: 1000 bytes\n" in out
    assert "size          1001 vertices, 2001 faces" in out
    assert out.count("  copy ") == 2 and '"strength": 1.0' in out
    assert main(["registry", "show", target, str(first), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["references"] == {"0": 1000, "64": 1000, "128": 1000}
    assert report["asset"]["copy_count"] == 2 and len(report["copies"]) == 2


def test_remove(filled, capsys):
    target, first, second = filled
    assert main(["registry", "remove", target, "--copy", "2"]) == 0
    assert capsys.readouterr().out == "removed copy 2\n"
    assert main(["registry", "remove", target, "--asset", str(second)]) == 0
    assert capsys.readouterr().out == f"removed asset {second} (asset2.ply) and its 1 copy\n"
    with Registry.open(target) as registry:
        assert [a.id for a in registry.assets()] == [first]
        assert [c.id for c in registry.copies()] == [1]
    assert main(["registry", "remove", target, "--copy", "2"]) == 2
    assert "no copy with id 2" in _one_line_error(capsys)


@pytest.mark.parametrize(
    "argv",
    [
        ["show", "DB", "99"],
        ["remove", "DB", "--asset", "99"],
        ["remove", "DB"],
        ["remove", "DB", "--asset", "1", "--copy", "1"],
        ["show", "DB", "zero"],
        ["frobnicate", "DB"],
    ],
)
def test_bad_lines_exit_2(filled, capsys, argv):
    target = filled[0]
    assert main(["registry", *(target if a == "DB" else a for a in argv)]) == 2
    _one_line_error(capsys)


@pytest.mark.parametrize("action", [["list"], ["show", "1"], ["remove", "--copy", "1"]])
def test_a_missing_registry_is_not_created(tmp_path, capsys, action):
    path = tmp_path / "none.db"
    assert main(["registry", action[0], str(path), *action[1:]]) == 2
    assert _one_line_error(capsys) == f"meshwm: error: {path}: no such registry\n"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "content", [b"\x00garbage" * 300, b"SQLite format 3\x00" + b"\xff" * 5000, b""]
)
def test_a_corrupt_registry_exits_2(tmp_path, capsys, content):
    path = tmp_path / "r.db"
    path.write_bytes(content)
    assert main(["registry", "list", str(path)]) == 2
    assert _one_line_error(capsys).startswith(f"meshwm: error: {path}: ")
    assert path.read_bytes() == content


def test_a_postgresql_password_is_never_shown(capsys):
    pytest.importorskip("psycopg")
    assert main(["registry", "list", "postgresql://studio:sekrit@127.0.0.1:1/registry"]) == 2
    err = _one_line_error(capsys)
    assert "sekrit" not in err and "studio:***@127.0.0.1:1/registry" in err


def test_the_command_as_a_process(tmp_path):
    """The installed entry point: one stderr line and exit 2, no traceback, no file."""
    path = tmp_path / "none.db"
    done = subprocess.run(
        [sys.executable, "-m", "meshwm", "registry", "list", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == f"meshwm: error: {path}: no such registry\n"
    assert not path.exists()
