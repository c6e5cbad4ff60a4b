"""A drive keeps freed memory for its next arrays (app/drive/memory.py, glibc only): an array
of tens of megabytes comes from the heap, not from a mapping of its own, and its pages stay
with the process when it is freed, ready for the next array (glibc's mallinfo2 says where
each byte is)."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc")

WHERE = """
import ctypes, sys
import numpy as np
NAMES = "arena ordblks smblks hblks hblkhd usmblks fsmblks uordblks fordblks keepcost"
class Info(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in NAMES.split()]
libc = ctypes.CDLL("libc.so.6")
if not hasattr(libc, "mallinfo2"):
    print("none"); sys.exit()
libc.mallinfo2.restype = Info
if sys.argv[1] == "kept":
    from wildscan.app.drive.memory import keep_freed_memory
    assert keep_freed_memory() and keep_freed_memory()  # once a process; asking again is harmless
array = np.empty(5_000_000)  # 40 MB
array[:] = 1.0
mapped = libc.mallinfo2().hblkhd
del array
print(mapped, libc.mallinfo2().fordblks)
"""


def where(mode: str) -> tuple[int, int]:
    """(bytes in mappings of their own while the array lives, free heap bytes once it is
    freed) in a fresh process (its malloc untouched by this one's)."""
    done = subprocess.run(
        [sys.executable, "-c", WHERE, mode], capture_output=True, text=True, check=True, timeout=300
    )
    if done.stdout.strip() == "none":
        pytest.skip("glibc without mallinfo2")
    mapped, free = done.stdout.split()
    return int(mapped), int(free)


def test_an_array_comes_from_the_heap_and_its_pages_stay_for_the_next():
    mapped, free = where("kept")
    assert mapped < 40_000_000 and free >= 40_000_000
    mapped, free = where("default")
    assert mapped >= 40_000_000 and free < 40_000_000  # glibc's own way: a mapping, given back


def test_one_heap_is_set_once_freed_memory_is_kept():
    """one_heap (glibc's M_ARENA_MAX = 1, app/drive/memory.py) is accepted by malloc in a fresh
    process, after keep_freed_memory, and asking again is harmless."""
    code = (
        "from wildscan.app.drive.memory import keep_freed_memory, one_heap\n"
        "print(one_heap(), keep_freed_memory(), one_heap())"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert done.stdout.split() == ["True", "True", "True"]
