"""A scan's rays cast from several threads at once, where the backend allows it (numpy only).

A full realistic scan casts about a million sub-rays, and the cast is most of its time. A
backend whose `cast` releases the GIL while it traces (THREADS in its capabilities: the
embree backend, whose `run` traces with the GIL released) can cast parts of one batch in
parallel threads. Each ray's answer is its own (the caster traces one ray after another;
the float64 settling and refinement are per ray), so the joined answer is the same bytes
as one call's, in the same order, however many threads.

How many: the backend's own `threads` when set (a dataset worker's: 1), else
WILDSCAN_CAST_THREADS when set, else OMP_NUM_THREADS when set (Dask sets it to 1
in every dataset worker process, which already has a core to itself; so does a SLURM job
script that asks for one CPU), else the CPUs this process may run on.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

import numpy as np

from ..backend import THREADS, RayBackend
from ..errors import UserError
from ..hits import RayHits
from .heap import keep_freed_memory

THREADS_ENV = "WILDSCAN_CAST_THREADS"
# A part smaller than this is not worth a thread (the caster's own set-up per call). Each
# thread gets one part; a large cast (the realistic model's million sub-rays) a few a thread,
# so that one slow part (a forest's crowns) does not hold the others, but never parts below
# BALANCE_PART: each part's own settling and bookkeeping cost about 0.5 ms of CPU (measured
# on a Hokuyo scan: 8 parts took 3.6 ms more than 2), more than the balance gains on a
# paper scan of 30k-200k rays.
MIN_PART = 8_192
BALANCE_PART = 50_000
PARTS_PER_THREAD = 4

_pool: ThreadPoolExecutor | None = None
_worker = threading.local()  # `busy` set in the pool's own threads
T = TypeVar("T")


def in_worker() -> bool:
    """Whether this thread is one of the pool's: a part run there (a realistic scan's block
    of beams, core/realism/realistic.py) splits nothing further, it casts and computes inline (a
    worker waiting on parts queued behind it could wait for ever)."""
    return getattr(_worker, "busy", False)


def _mark_worker() -> None:
    _worker.busy = True


def cast_threads() -> int:
    """The threads a cast may use (see the module docstring)."""
    value = os.environ.get(THREADS_ENV, "").strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise UserError(f"must be a whole number of threads from 1, got {value!r}", setting=THREADS_ENV)
        return int(value)
    omp = os.environ.get("OMP_NUM_THREADS", "").strip()
    if omp.isdigit() and int(omp) >= 1:
        return int(omp)
    if hasattr(os, "sched_getaffinity"):
        return max(len(os.sched_getaffinity(0)), 1)
    return os.cpu_count() or 1


def backend_threads(backend: RayBackend) -> int:
    """The threads `backend`'s casts may be split over: 1 unless it has THREADS; then its own
    `threads` when set (a dataset worker's backend says 1: one worker a core), else
    cast_threads()."""
    if THREADS not in backend.capabilities:
        return 1
    own = getattr(backend, "threads", None)
    return int(own) if own else cast_threads()


def parts(count: int, threads: int, chunk: int | None = None) -> list[slice]:
    """Consecutive slices covering `count` rays: of `chunk` rays when given (progress is
    reported after each), else one per thread, or a few per thread where each still has
    BALANCE_PART rays; none smaller than MIN_PART."""
    if chunk is None:
        pieces = 1
        if threads > 1:
            per_thread = min(max(count // (BALANCE_PART * threads), 1), PARTS_PER_THREAD)
            pieces = max(min(per_thread * threads, count // MIN_PART), 1)
        chunk = -(-count // pieces) if count else 1
    return [slice(start, min(start + chunk, count)) for start in range(0, count, chunk)] or [slice(0, 0)]


def cast_parts(
    backend: RayBackend,
    cast: Callable[[np.ndarray, np.ndarray, float], RayHits],
    origin: np.ndarray,
    dirs: np.ndarray,
    max_range: float,
    chunk: int | None = None,
    done: Callable[[int, int], None] | None = None,
) -> RayHits:
    """`cast` of every ray, in parts (threaded where the backend allows it), joined in ray
    order; `done(rays cast so far, all rays)` after each part, in order. `origin` is one
    point or one per ray."""
    total = len(dirs)
    if in_worker():  # a part of a larger job: one call, its progress the job's own to report
        return cast(origin, dirs, max_range)
    threads = backend_threads(backend)
    pieces = parts(total, threads, chunk)
    if len(pieces) == 1 and done is None:
        return cast(origin, dirs, max_range)
    per_ray = np.ndim(origin) == 2

    def one(part: slice) -> RayHits:
        return cast(origin[part] if per_ray else origin, dirs[part], max_range)

    results = _pool_of(threads).map(one, pieces) if threads > 1 and len(pieces) > 1 else map(one, pieces)
    out = []
    for part, hits in zip(pieces, results):
        out.append(hits)
        if done is not None:
            done(part.stop, total)
    return out[0] if len(out) == 1 else RayHits.joined(out)


def in_parts(fn: Callable[[slice], T], count: int, size: int, threads: int | None = None) -> list[T]:
    """`fn` of consecutive slices of `size` covering `count` items, in order, on `threads`
    threads (None: cast_threads(); numpy releases the GIL inside its array operations)."""
    pieces = [slice(start, min(start + size, count)) for start in range(0, count, size)] or [slice(0, 0)]
    threads = cast_threads() if threads is None else threads
    if threads > 1 and len(pieces) > 1 and not in_worker():
        return list(_pool_of(threads).map(fn, pieces))
    return [fn(piece) for piece in pieces]


def started(fn: Callable[[], T], threads: int | None = None) -> Callable[[], T]:
    """`fn()` begun on the pool while the caller goes on (inline, now, with one thread or from
    a pool thread); returns what gives its result, waiting for it if need be."""
    threads = cast_threads() if threads is None else threads
    if threads > 1 and not in_worker():
        return _pool_of(threads).submit(fn).result
    value = fn()
    return lambda: value


def _pool_of(threads: int) -> ThreadPoolExecutor:
    """One pool for the process, grown when more threads are asked for."""
    global _pool
    if _pool is None or _pool._max_workers < threads:
        keep_freed_memory()  # the threads' arrays not faulted in afresh block after block (heap.py)
        if _pool is not None:
            _pool.shutdown(wait=False)
        _pool = ThreadPoolExecutor(
            max_workers=threads, thread_name_prefix="wildscan-cast", initializer=_mark_worker
        )
    return _pool
