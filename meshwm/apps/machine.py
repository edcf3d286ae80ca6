"""What machine a benchmark ran on: CPU, OS, Python and package versions.

One source for ``meshwm bench`` (:func:`versions_info`, the ``machine`` field of ``bench.json``)
and the scripts of ``scripts/`` (:func:`machine_info`, through ``scripts/_machine.py``).
"""

from __future__ import annotations

import contextlib
import os
import platform
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import numpy as np

__all__ = ["machine_info", "package_version", "platform_info", "processor_name", "versions_info"]


def package_version(name: str) -> str:
    """Installed version of a distribution, or ``"not installed"``.

    Examples
    --------
    >>> package_version("no-such-distribution-here")
    'not installed'
    """
    try:
        return version(name)
    except PackageNotFoundError:
        return "not installed"


def processor_name() -> str:
    """The CPU's name: :func:`platform.processor`, else ``model name`` of ``/proc/cpuinfo``.

    ``""`` when neither says (:func:`platform_info` then falls back to the machine type).
    """
    cpu = platform.processor()
    if not cpu:
        with contextlib.suppress(OSError):
            with open("/proc/cpuinfo", encoding="utf-8") as stream:
                cpu = next(
                    (ln.split(":", 1)[1].strip() for ln in stream if ln.startswith("model name")),
                    "",
                )
    return cpu


def platform_info() -> dict[str, Any]:
    """``cpu_count``, ``processor``, ``uname`` (system, release, machine) and ``python``."""
    uname = platform.uname()
    return {
        "cpu_count": os.cpu_count(),
        "processor": processor_name() or uname.machine,
        "uname": f"{uname.system} {uname.release} {uname.machine}",
        "python": platform.python_version(),
    }


def machine_info(*packages: str) -> dict[str, Any]:
    """:func:`platform_info` and numpy's version, plus one key per name of ``packages``.

    The scripts' record: flat, each package's version under its own name.
    """
    info = {**platform_info(), "numpy": np.__version__}
    info.update({name: package_version(name) for name in packages})
    return info


def versions_info(*packages: str) -> dict[str, Any]:
    """:func:`platform_info` plus ``versions``: meshwm's and those of ``packages``.

    The bench's record (``machine`` in ``bench.json``).
    """
    from meshwm import __version__

    return {
        **platform_info(),
        "versions": {"meshwm": __version__, **{p: package_version(p) for p in packages}},
    }
