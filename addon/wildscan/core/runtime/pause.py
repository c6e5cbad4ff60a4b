"""A test hook, nothing else: with WILDSCAN_TEST_PAUSE_AT=MOMENT[:N] in the environment the
process stops at the N-th time (default the first) it reaches MOMENT, prints
`wildscan-test-pause MOMENT` on stderr and waits (up to PAUSE_SECONDS) so a test can send
SIGINT or SIGTERM at exactly that moment instead of guessing with timers.

The moments: `starting` (the first line of the `wildscan` script or a Blender script),
`bpy-import` (while the bpy module loads), `casting` (rays about to be cast), `writing`
(an output group's temporary files written, not yet renamed into place), `renamed` (one
file of a group renamed into place, the others not yet), `card` (a dataset's scans all
recorded, its card about to be written), `stopping` (a dataset run closing its cluster after
a stop). With WILDSCAN_TEST_RESUME=PATH too, the wait also
ends when that file exists (a test lets the process go on).
Without the variable `pause_here` costs one dictionary lookup.
"""

from __future__ import annotations

import os
import sys
import time
from collections import Counter
from collections.abc import Callable

ENV = "WILDSCAN_TEST_PAUSE_AT"
RESUME_ENV = "WILDSCAN_TEST_RESUME"
PAUSE_SECONDS = 30.0
MARKER = "wildscan-test-pause"
_reached: Counter = Counter()


def pause_here(moment: str, until: Callable[[], bool] = lambda: False) -> None:
    """Wait here if the test hook asks for `moment`; `until()` ends the wait early (a
    signal noted while signals are deferred, which does not interrupt a sleep)."""
    wanted = os.environ.get(ENV)
    if not wanted:
        return
    name, _, nth = wanted.partition(":")
    if name != moment:
        return
    _reached[moment] += 1
    if _reached[moment] != int(nth or 1):
        return
    sys.stderr.write(f"{MARKER} {moment}\n")
    sys.stderr.flush()
    resume = os.environ.get(RESUME_ENV)
    deadline = time.monotonic() + PAUSE_SECONDS
    while time.monotonic() < deadline and not until() and not (resume and os.path.exists(resume)):
        time.sleep(0.01)
