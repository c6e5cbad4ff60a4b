"""A drive keeps freed memory for its next arrays (app/drive/memory.py, glibc only): arrays of
a few megabytes made and freed over and over (a sweep's pattern) reuse the heap's pages
instead of faulting in fresh ones each time."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's malloc")

CHURN = """
import resource, sys
import numpy as np
if sys.argv[1] == "kept":
    from wildscan.app.drive.memory import keep_freed_memory
    assert keep_freed_memory() and keep_freed_memory()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(100):
    live = []
    for size in (200_000, 600_000, 194_400, 2_000_000, 150_000, 5_000_000):
        array = np.empty(size)
        array[:] = 1.0
        live.append(array)
        if len(live) > 3:
            live.pop(0)
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def minor_faults(mode: str) -> int:
    """Page faults of the churn in a fresh process (its malloc untouched by this one's)."""
    done = subprocess.run([sys.executable, "-c", CHURN, mode], capture_output=True, text=True, check=True)
    return int(done.stdout)


def test_arrays_made_again_reuse_the_freed_pages():
    assert minor_faults("kept") * 5 < minor_faults("default")
