"""Freed memory kept for the next scan, where the C library allows it (glibc; numpy only).

A realistic scan allocates and frees a few hundred MB of arrays, a block of beams at a time
on the cast's threads (core/runtime/threads.py). glibc gives each thread's freed memory back to the
kernel once its heap's free top passes the trim threshold, and a large array past the mmap
threshold is mapped afresh each time, so the next block's arrays fault their pages in again
and the kernel zeroes them: 8,500 page faults and 36 ms of kernel time in a full r_h = 1 deg
realistic scan of seed 0's forest on two threads, 99 faults and none measurable with the two
thresholds below (`mallopt`, glibc's malloc.h: M_TRIM_THRESHOLD = -1, M_MMAP_THRESHOLD = -3;
an mmap threshold above 32 MB is refused on 64-bit glibc, HEAP_MAX_SIZE / 2).

The cost: memory freed stays in the process, so its resident size after a scan stays near
the scan's peak (the peak itself does not change). Only a process that casts on several
threads asks for it (threads.py, when its pool is made): a dataset worker casts on one.
Elsewhere (another C library, no libc found) nothing changes.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import platform

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
TRIM_THRESHOLD = 1 << 30  # bytes of free heap top kept before any is given back
MMAP_THRESHOLD = 32 << 20  # bytes from which an array is mapped on its own (glibc's most)


@functools.lru_cache(maxsize=1)
def keep_freed_memory() -> bool:
    """Ask glibc's malloc to keep freed memory for reuse (see the module docstring), once a
    process; whether it agreed."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)) and bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD))
