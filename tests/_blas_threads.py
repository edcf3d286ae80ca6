"""Run a probe under 1 and 2 BLAS threads: what it prints must not depend on them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TESTS = str(Path(__file__).resolve().parent)


def printed_under_blas_threads(probe: str) -> set[str]:
    """What ``python -c probe TESTS`` prints with one BLAS thread and with two (the probe
    finds the test helpers through ``sys.argv[1]``)."""
    printed = set()
    for threads in ("1", "2"):
        env = {**os.environ, "OPENBLAS_NUM_THREADS": threads, "OMP_NUM_THREADS": threads}
        out = subprocess.run(
            [sys.executable, "-c", probe, TESTS],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        )
        printed.add(out.stdout.strip())
    return printed
