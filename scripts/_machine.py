"""What machine a benchmark ran on (shared by the scripts in this folder).

The scripts' name for :mod:`meshwm.apps.machine`, which ``meshwm bench`` uses too.
"""

from __future__ import annotations

import sys
from pathlib import Path

try:
    import meshwm  # noqa: F401
except ImportError:  # run from a checkout: the scripts put the repo root on sys.path
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from meshwm.apps.machine import machine_info, package_version

__all__ = ["machine_info", "package_version"]
