"""Let glibc keep freed memory for reuse in long numeric runs (private).

Decoding a mesh makes hundreds of short-lived arrays of a few megabytes.  With glibc's
defaults each one comes from fresh pages: arrays over the (dynamic) mmap threshold are mapped
and unmapped, and the top of the heap is trimmed back to the system as soon as more than the
trim threshold is free, so the next array faults its pages in again.  At N = 256 that was
about 3,300 page faults per verified file, and about a fifth of its time (measured on 50 of
the files ``scripts/bench_verify.py`` makes: 48 ms per file, 38 ms tuned).  Raising both
thresholds keeps the freed memory in the process for the next array: about 450 faults per
file, the same peak memory (0.3 GB).

A large mesh's arrays are larger than any threshold (at 5M vertices each per-corner array is
0.24 GB), so they were still mapped and unmapped one by one, every page faulted in and zeroed
by the kernel again: the kept embedding of igea Loop-subdivided to 2.1M vertices spent 32 s of
its 123 s in the kernel (20 s of 108 s with a 64 MB mmap threshold).  A command-line run (one
command, then exit) maps only allocations over 256 MB on its own (at 5M vertices, the
per-face corner positions and the like) and never trims its heap: 2.1M 91 s (5 s in the
kernel), 5M 361 s → 250 s (2026-12-04, ``embed`` timed in one process); the processes of
``verify --jobs``, forked from it, inherit that.  With nothing mapped at all, a grid embedding's
heap at 5M vertices came within 0.02 GiB of issue 16's 8 GB budget (7.43 GiB, 7.59 in another
run); over 256 MB mapped, 7.37 / 7.39 GiB at N = 256 / 1024 and 7.40 for the kept embedding
(2026-12-05).  Until then a command writing a geometry image's grid kept a worker's
thresholds, and paid for it in page faults: igea (134k vertices) at N = 1024 2.67-2.79 s
against 2.43-2.52 s (1.0-1.3 s of system time against 0.5-0.6).  A Dask worker keeps a
worker's thresholds: it lives on after the files it checks, so one huge file's memory does
not stay with it.

Only the processes meshwm runs itself call this (the command line, and the workers of
:mod:`meshwm.apps.batch`, Dask workers included, whose nanny sets ``MALLOC_TRIM_THRESHOLD_`` to
64 KiB by default); importing meshwm changes nothing.  Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib
import sys

__all__ = ["keep_freed_memory"]

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
_M_ARENA_MAX = -8
#: Arrays up to this size come from the heap rather than their own mapping (a worker).
MMAP_THRESHOLD = 64 << 20
#: Free memory at the top of the heap is returned to the system beyond this (a worker).
TRIM_THRESHOLD = 256 << 20
#: Arrays up to this size come from the heap in a process that keeps its memory until it exits.
UNTIL_EXIT_MMAP_THRESHOLD = 256 << 20
#: mallopt's largest value: a process that keeps its memory until it exits never trims.
_NEVER = 2**31 - 1

_done = False


def keep_freed_memory(*, until_exit: bool = False) -> bool:
    """Keep freed memory in this process for reuse, once; True if glibc took the settings.

    Parameters
    ----------
    until_exit : bool, default False
        False (a worker that checks file after file): glibc's mmap threshold raised to
        :data:`MMAP_THRESHOLD` and its trim threshold to :data:`TRIM_THRESHOLD`, so arrays
        larger than that still go back to the system when freed.  True (one command on one
        mesh, then exit): only allocations over :data:`UNTIL_EXIT_MMAP_THRESHOLD` are mapped
        on their own and the heap is never trimmed, so even a 5M-vertex mesh's per-corner
        arrays reuse the pages of the last ones; and every thread allocates from the one
        arena, so what the second thread of :mod:`meshwm._concurrent` frees is reused by the
        first (with an arena of its own, the kept embedding at 5M vertices peaked at 7.47 GiB
        against 7.43 without the thread; one arena: 7.40).
    """
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
    if until_exit:
        ok = mallopt(_M_MMAP_THRESHOLD, UNTIL_EXIT_MMAP_THRESHOLD) == 1
        ok = mallopt(_M_TRIM_THRESHOLD, _NEVER) == 1 and ok
        ok = mallopt(_M_ARENA_MAX, 1) == 1 and ok
        if ok:
            _no_huge_pages()
    else:
        ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
        ok = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD) == 1 and ok
    _done = ok
    return ok


def _no_huge_pages() -> None:
    """Stop numpy asking for transparent huge pages on its arrays (what
    ``NUMPY_MADVISE_HUGEPAGE=0`` does at numpy's import).

    numpy advises huge pages (``madvise(MADV_HUGEPAGE)``) on every array of 4 MB or more.  On
    mapped arrays that cost nothing here, but with the heap kept (above) the advice lands on
    pieces of the heap, and a kernel that defragments on advised faults (``defrag`` =
    ``madvise``, a common default) compacts memory in the faulting thread: touching 1 GB of
    fresh 20 MB arrays took 0.4 s without the advice and 0.4-2.0 s with it.  igea at 134k
    vertices, the command's embedding (8 runs each way, alternated): at N = 1024 the system
    time 0.63-0.75 s against 0.32-0.36 s, the wall time's median 2.47 against 2.32 s; kept
    2.56 against 2.50 s; the floor of ``scripts/bench_scale.py`` the same (0.75, 0.73 s).
    """
    for name in ("numpy._core.multiarray", "numpy.core.multiarray"):
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        setter = getattr(module, "_set_madvise_hugepage", None)
        if setter is not None:
            setter(False)
            return
