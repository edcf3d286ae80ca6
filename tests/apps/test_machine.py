"""Tests for :mod:`meshwm.apps.machine`: the machine record of the bench and the scripts."""

from __future__ import annotations

import os
import platform

from meshwm import __version__
from meshwm.apps.machine import machine_info, package_version, platform_info, versions_info

PLATFORM_KEYS = ["cpu_count", "processor", "uname", "python"]


def test_package_version():
    assert package_version("numpy") != "not installed"
    assert package_version("no-such-distribution-here") == "not installed"


def test_platform_info():
    info = platform_info()
    assert list(info) == PLATFORM_KEYS
    assert info["cpu_count"] == os.cpu_count() and info["python"] == platform.python_version()
    assert info["processor"]  # the CPU's name, else the machine type


def test_machine_info_is_flat():
    info = machine_info("scipy", "no-such-distribution-here")
    assert list(info) == [*PLATFORM_KEYS, "numpy", "scipy", "no-such-distribution-here"]
    assert info["no-such-distribution-here"] == "not installed"


def test_versions_info_nests_the_versions():
    info = versions_info("scipy")
    assert list(info) == [*PLATFORM_KEYS, "versions"]
    assert info["versions"] == {"meshwm": __version__, "scipy": package_version("scipy")}
