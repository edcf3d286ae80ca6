"""Tests for ``scripts/check_keys.py``: one payload under several keys on each mesh."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "check_keys.py"
sys.path.insert(0, str(SCRIPT.parent))


@pytest.mark.parametrize(
    "args, message",
    [
        (["--meshes", "nosuch"], "no such mesh: nosuch"),
        (["--meshes", "holes35", "--keys", "0"], "--keys must be 1..1000"),
        (["--meshes", "holes35", "--jobs", "0"], "--jobs must be at least 1"),
        (["--meshes", "holes35", "--out", "/nonexistent/keys.md"], "--out: no such directory"),
    ],
)
def test_bad_options_are_one_line_and_exit_2(args, message):
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2 and done.stdout == ""
    assert message in done.stderr.strip().splitlines()[-1]
    assert "Traceback" not in done.stderr


def test_a_row_counts_keys_reinforcements_and_refusals():
    from check_keys import _row

    good = {"carried": True, "mrms": 1.5e-4, "hausdorff": 1.2e-3, "wrong_key": False}
    results = [
        {**good, "reinforced": False, "ber": 0.0, "detected": True},
        {**good, "reinforced": True, "ber": 0.001, "detected": True},
        {"carried": False, "ber": 0.034},
    ]
    assert _row("kitten", results) == (
        "| kitten | 2/3 | 1 | 0.1% | 0.0150% | 0.120% | 2/2 | 0 | 3.4% |"
    )
