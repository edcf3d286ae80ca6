"""What machine a benchmark ran on (shared by the scripts in this folder)."""

from __future__ import annotations

import os
import platform
from importlib.metadata import PackageNotFoundError, version

import numpy as np


def package_version(name: str) -> str:
    """Installed version of a distribution, or "not installed"."""
    try:
        return version(name)
    except PackageNotFoundError:
        return "not installed"


def machine_info(*packages: str) -> dict:
    """CPU, OS, Python and numpy versions, plus the versions of ``packages``."""
    cpu = platform.processor()
    if not cpu:
        try:
            with open("/proc/cpuinfo", encoding="utf-8") as stream:
                cpu = next(
                    (ln.split(":", 1)[1].strip() for ln in stream if ln.startswith("model name")),
                    "",
                )
        except OSError:
            cpu = ""
    uname = platform.uname()
    info = {
        "cpu_count": os.cpu_count(),
        "processor": cpu or uname.machine,
        "uname": f"{uname.system} {uname.release} {uname.machine}",
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    info.update({name: package_version(name) for name in packages})
    return info
