"""How long ``meshwm --help`` and ``meshwm --version`` take, against ``import numpy``.

Runs, as whole processes and taking turns, ``python -c "import numpy"``, ``python -m meshwm
--help`` and ``python -m meshwm --version``, N times each, and prints the median wall time of each
and its ratio to numpy's.  The target is at most 3x: the CLI's start-up should cost little more
than NumPy's, which it needs anyway.  A benchmark: it prints its figures and PASS or FAIL, and
exits 0 either way.

Usage::

    python scripts/bench_help.py [-n 10]

Run from anywhere: the processes run with the repository root on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Largest ratio of a CLI start-up to ``import numpy`` that passes.
TARGET = 3.0
COMMANDS = {
    "import numpy": [sys.executable, "-c", "import numpy"],
    "meshwm --help": [sys.executable, "-m", "meshwm", "--help"],
    "meshwm --version": [sys.executable, "-m", "meshwm", "--version"],
}


def _seconds(argv: list[str], env: dict[str, str]) -> float:
    started = time.perf_counter()
    subprocess.run(argv, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, check=True)
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-n", type=int, default=10, help="runs of each command (10)")
    args = parser.parse_args()
    paths = [str(ROOT), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(paths))
    times: dict[str, list[float]] = {name: [] for name in COMMANDS}
    for argv in COMMANDS.values():  # one untimed run each: the file cache, .pyc files
        _seconds(argv, env)
    for _ in range(max(args.n, 1)):
        for name, argv in COMMANDS.items():  # alternately, so drift hits every command alike
            times[name].append(_seconds(argv, env))
    median = {name: statistics.median(t) for name, t in times.items()}
    base = median["import numpy"]
    print(
        f"{'command':<18} {'median':>9} {'vs numpy':>9}   ({len(times['import numpy'])} runs each)"
    )
    for name, seconds in median.items():
        print(f"{name:<18} {1000 * seconds:7.1f} ms {seconds / base:8.2f}x")
    worst = max(median[name] / base for name in COMMANDS if name != "import numpy")
    verdict = "PASS" if worst <= TARGET else "FAIL"
    print(f"target: at most {TARGET:g}x the time of import numpy: {verdict} ({worst:.2f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
