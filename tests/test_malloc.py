"""Tests for :mod:`meshwm._malloc`: freed memory kept for reuse in meshwm's own processes."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from meshwm import _malloc

glibc = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")

# glibc's mallinfo2 from a probe process (heap bytes, mapped bytes, free bytes in the heap).
_MALLINFO = """
import ctypes, sys, threading
import numpy as np
class Info(ctypes.Structure):
    _fields_ = [(k, ctypes.c_size_t) for k in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]
libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = Info
"""

# An 8 MB array, as the decoder makes hundreds of: where it came from, and whether its memory
# stays in the process once freed (mapped bytes, free bytes in the heap).
_PROBE = (
    _MALLINFO
    + """
if sys.argv[1] != "plain":
    from meshwm._malloc import keep_freed_memory
    assert keep_freed_memory(until_exit=sys.argv[1] == "until_exit")
a = np.ones(int(sys.argv[2]))
mapped = libc.mallinfo2().hblkhd
del a
print(mapped, libc.mallinfo2().fordblks)
"""
)


def _probe(mode: str, size: int = 1 << 20) -> tuple[int, int]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE, mode, str(size)], capture_output=True, text=True, check=True
    )
    mapped, free = out.stdout.split()
    return int(mapped), int(free)


@glibc
def test_big_arrays_come_from_the_heap_and_stay_for_reuse():
    """glibc's defaults map an 8 MB array on its own and unmap it when freed (the next one
    faults its pages in again); tuned, it comes from the heap and its memory stays there."""
    try:
        plain = _probe("plain")
    except subprocess.CalledProcessError:
        pytest.skip("no mallinfo2 (glibc < 2.33)")
    tuned = _probe("tuned")
    eight = 8 << 20
    assert plain[0] >= eight and plain[1] < eight
    assert tuned[0] < eight and tuned[1] >= eight


@glibc
def test_a_one_command_process_keeps_what_a_worker_gives_back():
    """A 128 MB array (a 5M-vertex mesh's per-corner arrays are 240 MB): a worker's thresholds
    still map it on its own and give it back; a process that keeps its memory until it exits
    takes it from the heap and keeps it for the next one."""
    size = 128 << 20
    items = size // 8  # float64
    try:
        plain = _probe("plain", items)
    except subprocess.CalledProcessError:
        pytest.skip("no mallinfo2 (glibc < 2.33)")
    worker = _probe("worker", items)
    until_exit = _probe("until_exit", items)
    assert plain[0] >= size and plain[1] < size
    assert worker[0] >= size and worker[1] < size
    assert until_exit[0] < size and until_exit[1] >= size


@glibc
def test_a_one_command_process_maps_what_is_larger_than_its_threshold():
    """Over 256 MB (a 5M-vertex mesh's per-face corner positions, 0.72 GB) an array is mapped
    on its own and given back when freed, so such arrays do not fragment a heap that is never
    trimmed (a grid embedding at 5M vertices came within 0.02 GiB of the 8 GB budget)."""
    size = _malloc.UNTIL_EXIT_MMAP_THRESHOLD + (64 << 20)
    try:
        mapped, free = _probe("until_exit", size // 8)
    except subprocess.CalledProcessError:
        pytest.skip("no mallinfo2 (glibc < 2.33)")
    assert mapped >= size and free < size


@glibc
def test_keep_freed_memory_is_idempotent():
    assert _malloc.keep_freed_memory() is True
    assert _malloc.keep_freed_memory() is True


def test_importing_meshwm_does_not_tune_malloc():
    code = "import meshwm, meshwm.watermark, meshwm.apps.batch, meshwm._malloc as m; print(m._done)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


_THREAD_PROBE = (
    _MALLINFO
    + """
from meshwm._malloc import keep_freed_memory
assert keep_freed_memory(until_exit=True)
size = 128 << 20
def work():
    a = np.ones(size // 8)
    del a
helper = threading.Thread(target=work)
helper.start()
helper.join()
before = libc.mallinfo2().arena
b = np.ones(size // 8)
print(libc.mallinfo2().arena - before)
"""
)


@glibc
def test_a_one_command_process_reuses_what_a_second_thread_freed():
    """meshwm runs a mesh's connectivity work in a second thread (meshwm._concurrent): in a
    process that keeps its memory until it exits, what that thread freed is reused by the
    first (one arena), so the peak is not the two threads' peaks added up."""
    try:
        out = subprocess.run(
            [sys.executable, "-c", _THREAD_PROBE], capture_output=True, text=True, check=True
        )
    except subprocess.CalledProcessError:
        pytest.skip("no mallinfo2 (glibc < 2.33)")
    assert int(out.stdout) < 1 << 20  # the 128 MB came from the freed memory


_HUGE = """
import sys
from numpy._core.multiarray import _get_madvise_hugepage
if sys.argv[1] != "plain":
    from meshwm._malloc import keep_freed_memory
    assert keep_freed_memory(until_exit=sys.argv[1] == "until_exit")
print(_get_madvise_hugepage())
"""


@glibc
@pytest.mark.parametrize(
    ("mode", "advised"), [("plain", "True"), ("worker", "True"), ("until_exit", "False")]
)
def test_a_one_command_process_does_not_advise_huge_pages_on_its_heap(mode, advised):
    """numpy advises huge pages on arrays of 4 MB or more; on a kept heap that made the kernel
    compact memory in the faulting thread (see ``_no_huge_pages``): a one-command process
    turns the advice off; a worker, and a process that never asked, keep numpy's default."""
    if not hasattr(np, "_core"):
        pytest.skip("numpy < 2 (the setting is numpy.core's there)")
    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    out = subprocess.run(
        [sys.executable, "-c", _HUGE, mode], capture_output=True, text=True, check=True, env=env
    ).stdout.strip()
    if mode == "plain" and out == "False":
        pytest.skip("numpy does not advise huge pages on this kernel")
    assert out == advised
