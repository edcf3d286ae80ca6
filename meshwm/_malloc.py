"""Let glibc keep freed memory for reuse in long numeric runs (private).

Decoding a mesh makes hundreds of short-lived arrays of a few megabytes.  With glibc's
defaults each one comes from fresh pages: arrays over the (dynamic) mmap threshold are mapped
and unmapped, and the top of the heap is trimmed back to the system as soon as more than the
trim threshold is free, so the next array faults its pages in again.  At N = 256 that was
about 3,300 page faults per verified file, and about a fifth of its time (measured on 50 of
the files ``scripts/bench_verify.py`` makes: 48 ms per file, 38 ms tuned).  Raising both
thresholds keeps the freed memory in the process for the next array: about 450 faults per
file, the same peak memory (0.3 GB).

Only the processes meshwm runs itself call this (the command line, and the workers of
:mod:`meshwm.apps.batch`, Dask workers included, whose nanny sets ``MALLOC_TRIM_THRESHOLD_`` to
64 KiB by default); importing meshwm changes nothing.  Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["keep_freed_memory"]

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Arrays up to this size come from the heap rather than their own mapping.
MMAP_THRESHOLD = 64 << 20
#: Free memory at the top of the heap is returned to the system beyond this.
TRIM_THRESHOLD = 256 << 20

_done = False


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds for this process, once; True if they were set."""
    global _done
    if _done:
        return True
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
    ok = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok
    _done = ok
    return ok
