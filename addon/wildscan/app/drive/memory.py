"""Freed memory kept for the next array (glibc only): a drive allocates and frees arrays of a
few megabytes thousands of times (every chunk of rays, every sweep's clouds). glibc serves
each one above its mmap threshold (128 KiB at first, raised as such blocks are freed) with
fresh pages from the kernel, and every first touch of a 4 KiB page is a fault that zeroes it:
about a quarter of a 60 s drive's CPU time went there (system time, 230,000 minor faults a
run). With the threshold at 64 MiB and freed memory trimmed only beyond 128 MiB, those
arrays come from the heap and reuse its pages.

mallopt(3): M_TRIM_THRESHOLD = -1, M_MMAP_THRESHOLD = -3 (glibc's malloc.h), values in bytes;
setting them turns off glibc's own adjustment of both. Elsewhere (macOS, musl, Windows)
nothing is done.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
MMAP_THRESHOLD = 64 << 20  # bytes: arrays up to this size come from the heap
TRIM_THRESHOLD = 128 << 20  # bytes of freed heap kept before any is given back

_done = False


def keep_freed_memory() -> bool:
    """Tune glibc's malloc for many short-lived large arrays (once a process); True when done."""
    global _done
    if _done:
        return True
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
        gnu = libc.gnu_get_libc_version  # glibc's own: musl has no such function
    except (OSError, AttributeError):
        return False
    del gnu
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mapped = mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    _done = bool(mapped) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    return _done


def one_heap() -> bool:
    """All threads' arrays from one heap (glibc only; mallopt(3) M_ARENA_MAX = 1): a drive's
    threads (the casts', the next piece's world, the next sweep's rays, the writes behind:
    run.py, ahead.py) would each get an arena of their own, each keeping the memory its
    thread freed (TRIM_THRESHOLD a heap) and faulting in fresh pages for the next. Measured
    on a 300 m trail drive: peak 668 -> 555 MB, page faults 153,000 -> 78,000, the same time.
    Set before the threads start; True when done."""
    if not keep_freed_memory():
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    libc.mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return bool(libc.mallopt(M_ARENA_MAX, 1))
