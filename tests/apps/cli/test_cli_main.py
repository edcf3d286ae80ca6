"""Tests for :mod:`meshwm.apps.cli` itself: parsing, errors, the entry point, what it imports.

Run in-process through ``main(argv)``, except where the process itself is the point.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from meshwm.apps.cli import COMMANDS, _named_command, build_parser, main

ROOT = Path(__file__).parents[3]
ASSETS = ROOT / "assets"
#: Libraries that ``meshwm --help`` and ``--version`` must not load (seconds of start-up).
HEAVY = ("trimesh", "igl", "pymeshlab", "scipy", "matplotlib", "PIL", "dask")


def _one_line_error(capsys: pytest.CaptureFixture) -> str:
    err = capsys.readouterr().err
    assert err.endswith("\n")
    assert err.count("\n") == 1, err
    assert err.startswith("meshwm: ")
    assert "Traceback" not in err
    return err


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
        ["verify", "IN", "--key", "k", "--id", "0badc0de5ca1ab1e"],  # 16 letters: not an id
        ["verify", "IN", "--key", "k", "--id", "0xZZ"],
    ],
)
def test_bad_options_exit_2_with_one_line(argv, tmp_path, capsys):
    argv = [
        a.replace("IN", str(ASSETS / "spot.ply")).replace("OUT", str(tmp_path / "o")) for a in argv
    ]
    assert main(argv) == 2
    err = _one_line_error(capsys)
    assert "internal error" not in err
    assert list(tmp_path.iterdir()) == []


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


def _loaded_by(argv: list[str]) -> list[str]:
    """The HEAVY libraries a fresh interpreter has loaded after ``main(argv)``."""
    code = (
        "import sys\n"
        "from meshwm.apps.cli import main\n"
        "try:\n"
        f"    main({argv!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        f"heavy = {HEAVY!r}\n"
        "loaded = sorted({m.split('.')[0] for m in sys.modules} & set(heavy))\n"
        "print('LOADED', ' '.join(loaded))\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, check=True
    )
    last = proc.stdout.splitlines()[-1]
    assert last.startswith("LOADED"), proc.stdout
    return last.split()[1:]


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["-h"], []], ids=str)
def test_help_and_version_load_no_heavy_library(argv):
    assert _loaded_by(argv) == []


@pytest.mark.parametrize("command", list(COMMANDS))
def test_command_help_loads_no_heavy_library(command):
    assert _loaded_by([command, "--help"]) == []


@pytest.mark.parametrize("command", list(COMMANDS))
def test_the_named_command_alone_gets_the_same_parser(command, capsys):
    """main builds the options of the named command only: its help is the full parser's."""
    helps = []
    for parser in (build_parser(), build_parser([command])):
        with pytest.raises(SystemExit):
            parser.parse_args([command, "--help"])
        helps.append(capsys.readouterr().out)
    assert helps[0] == helps[1]
    assert "usage: meshwm " + command in helps[0]


def test_top_level_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name, command in COMMANDS.items():
        assert name in out
        assert command.HELP.split()[0] in out


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        ([], []),
        (["--help"], []),
        (["--version"], []),
        (["remesh", "in.ply", "-o", "embed"], ["remesh"]),
        (["--bogus", "verify", "x"], ["verify"]),
        (["--", "extract"], ["extract"]),
        (["-", "remesh"], ["-"]),
    ],
)
def test_named_command_is_the_first_positional_word(argv, named):
    assert _named_command(argv) == named


def test_unknown_command_lists_the_commands(capsys):
    assert main(["frobnicate"]) == 2
    err = _one_line_error(capsys)
    assert all(repr(name) in err for name in COMMANDS)


def test_every_command_is_a_module_with_add_parser_and_run():
    for name, command in COMMANDS.items():
        assert command.NAME == name
        assert getattr(command, "__name__", None) == f"meshwm.apps.cli.{name}"
        assert callable(command.add_parser) and callable(command.run)
        assert isinstance(command.HELP, str) and "\n" not in command.HELP
