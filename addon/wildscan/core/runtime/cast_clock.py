"""Seconds spent inside the ray caster's own calls, and inside scans (numpy-free, no bpy).

Why: a scan's limit is the caster (Embree casts a Hokuyo scan in ~15-25 ms on one core);
everything else a scan does is ours. `wildscan bench` reads this clock before and after each
suite and prints the cast's share of the scans' time and their ratio, so the distance to
that limit is always visible.

The backends over extracted triangles time their caster's call (Embree's `scene.run`, the
BVHTree loop) with `CLOCK.casting()`; a whole scan (core/scan.py run_scan, a drive's sweep)
is timed with `@scanning`, which also notes how much of the cast happened inside scans.
Seconds are wall-clock (time.perf_counter), summed per process; the cast's are the time
with at least one cast under way, so casts on parallel threads (core/runtime/threads.py) count once.
"""

from __future__ import annotations

import functools
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass
class Reading:
    """The clock at one moment; the difference of two says what happened between them."""

    cast: float = 0.0  # seconds inside the caster's own calls, anywhere
    scans: float = 0.0  # seconds inside scans (outermost scans only)
    cast_in_scans: float = 0.0  # of `cast`, the seconds inside scans

    def __sub__(self, other: Reading) -> Reading:
        return Reading(
            self.cast - other.cast, self.scans - other.scans, self.cast_in_scans - other.cast_in_scans
        )


class CastClock:
    def __init__(self) -> None:
        self.total = Reading()
        self._depth = 0  # scans within scans (a bench's wrapper) are counted once
        self._lock = threading.Lock()
        self._casting = 0  # casts under way (on parallel threads)
        self._since = 0.0  # when the first of them began

    def reading(self) -> Reading:
        t = self.total
        return Reading(t.cast, t.scans, t.cast_in_scans)

    @contextmanager
    def casting(self):
        """Time one call of the caster itself (overlapping calls on other threads once)."""
        with self._lock:
            if not self._casting:
                self._since = time.perf_counter()
            self._casting += 1
        try:
            yield
        finally:
            with self._lock:
                self._casting -= 1
                if not self._casting:
                    seconds = time.perf_counter() - self._since
                    self.total.cast += seconds
                    if self._depth:
                        self.total.cast_in_scans += seconds

    @contextmanager
    def scan(self):
        """Time one scan, placement to cloud."""
        self._depth += 1
        start = time.perf_counter()
        try:
            yield
        finally:
            self._depth -= 1
            if not self._depth:
                self.total.scans += time.perf_counter() - start


CLOCK = CastClock()


def scanning(fn):
    """Decorate a function that makes one scan: its time goes to the clock's scans."""

    @functools.wraps(fn)
    def timed(*args, **kwargs):
        with CLOCK.scan():
            return fn(*args, **kwargs)

    return timed


def cast_share_line(delta: Reading) -> str:
    """'cast X s of Y s (Z %), scan/cast R x': the caster's seconds inside the scans of a run
    beside the scans' seconds; without scans, the cast beside nothing."""
    if delta.scans > 0 and delta.cast_in_scans > 0:
        share = 100.0 * delta.cast_in_scans / delta.scans
        return (
            f"cast {delta.cast_in_scans:.2f} s of {delta.scans:.2f} s in scans ({share:.0f} %), "
            f"scan/cast {delta.scans / delta.cast_in_scans:.2f}x"
        )
    return f"cast {delta.cast:.2f} s (no scans timed)"
