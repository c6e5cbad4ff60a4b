"""A large cast split over threads (numpy only): the rays cut into consecutive parts, each
cast whole (the caster's first hits, settling, refinement) on its own thread, the answers
joined in order.

Why: Embree's `scene.run` (embreex) releases the GIL, and so do numpy's operations on large
arrays, so on an otherwise idle machine two threads finish one scan in close to half the
time. Every ray's answer depends on that ray alone (the settling decides ray by ray, and a
re-cast ray's answer does not depend on the others re-cast with it), so the parts joined
are the same bytes as one cast. A dataset worker keeps one thread (one worker a core:
threads there would only contend); a single scan or a drive uses the cores it has
(raycast/select.py).
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np

from ..core.hits import RayHits

MIN_RAYS_A_PART = 16_384  # below this a thread's start-up and the joining cost more than they save


def available_cores() -> int:
    """The processors this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def in_parts(cast: Callable[..., RayHits], threads: int, origins, directions, max_range, normals) -> RayHits:
    """`cast(origins, directions, max_range, normals)` over up to `threads` parts at once."""
    directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    count = len(directions)
    parts = min(int(threads), count // MIN_RAYS_A_PART)
    if parts <= 1:
        return cast(origins, directions, max_range, normals)
    from concurrent.futures import ThreadPoolExecutor

    origins = np.asarray(origins, dtype=np.float64)
    one_origin = origins.ndim == 1
    cuts = np.linspace(0, count, parts + 1).astype(int)
    spans = list(zip(cuts[:-1], cuts[1:]))

    def part(span) -> RayHits:
        start, stop = span
        from_ = origins if one_origin else origins.reshape(-1, 3)[start:stop]
        return cast(from_, directions[start:stop], max_range, normals)

    with ThreadPoolExecutor(parts, thread_name_prefix="wildscan-cast") as pool:
        return RayHits.joined(list(pool.map(part, spans)))
