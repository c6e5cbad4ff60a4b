"""How a dataset worker process keeps the memory it frees: glibc's malloc told, through the
environment the worker process starts with, to serve every array from one heap it never
hands back (the stdlib only).

Why: a world is a few hundred MB of arrays (seed 0's porous world: 77 MB of padded
triangles, 55 MB of vertices, a 229 MB cache entry read into one buffer) and as much again
of temporaries while it is built. glibc serves every block above 32 MB (and, in a thread's
own arena, above 64 MB) with its own mmap and hands it back to the kernel when freed. On a
virtual machine that returns a guest's free pages to its host (free page reporting, as the
2-core machine the targets are measured on does), memory freed a few seconds before is
faulted in from the host again: measured there, 512 MB touched again at once took 0.06 s
of CPU and 0.5 s of wall time, after 5 s idle 0.57 s and 4.4 s. A dataset worker frees its
last world and scans for seconds before it builds the next one, so every world paid that
again. With these settings the memory a worker frees stays in its heap and the next world
reuses it: seed 0 built and read back after another world, CPU 3.8-4.1 -> 2.8-3.1 s, wall
10-24 -> 8 s (a loaded machine).

- `arena_max=1`: one arena for every thread. Dask runs a task on a thread of its own, and a
  thread's arena serves a block larger than its 64 MB heaps by mmap whatever `mmap_max`
  says; the main arena grows its heap instead.
- `mmap_max=0`: no block by mmap.
- `trim_threshold`: the heap's free top is never handed back (the freed memory is the next
  world's). A worker's resident size is then the largest it has been: what its peak already
  was (`wildscan bench-dataset` prints each worker's peak).

Dask's nanny sets MALLOC_TRIM_THRESHOLD_=65536 for its workers (its pre-spawn-environ);
app/dataset/worker.py's `_keep_freed_memory` raises it again where set. Here it is left out,
so the tunables above hold. glibc reads them when the process starts: they cannot be set
from inside a running worker (its task thread has its arena already). Elsewhere than glibc
they are ignored.
"""

from __future__ import annotations

import os

NANNY_ENVIRON = "distributed.nanny.pre-spawn-environ"
WORKER_TUNABLES = "glibc.malloc.arena_max=1:glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=1099511627776"


def worker_environ(nanny_environ: dict) -> dict:
    """The environment a worker process starts with: Dask's `nanny_environ` (its
    pre-spawn-environ) without its trim threshold, and the tunables above after any the
    user has set."""
    env = {k: v for k, v in nanny_environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    given = os.environ.get("GLIBC_TUNABLES", "")
    if WORKER_TUNABLES not in given:  # the nanny sets its environment in this very process
        given = ":".join(t for t in (given, WORKER_TUNABLES) if t)
    env["GLIBC_TUNABLES"] = given
    return env
