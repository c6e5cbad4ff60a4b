"""core/runtime/cast_clock.py: the seconds inside the caster's own calls and inside scans, which
`wildscan bench` prints per suite. No speed is judged here: what is counted, and where."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.runtime.cast_clock import CLOCK, Reading, cast_share_line

pytest.importorskip("embreex")


def _ground_backend():
    from wildscan.raycast.embree_backend import EmbreeBackend
    from wildscan.raycast.geometry import from_triangles

    quad = [[[-50, -50, 0], [50, -50, 0], [50, 50, 0]], [[-50, -50, 0], [50, 50, 0], [-50, 50, 0]]]
    return EmbreeBackend(from_triangles(quad, class_id=1, instance=1))


def test_a_scan_counts_its_casts_inside_it_and_a_cast_alone_does_not():
    from wildscan.core.placement import Pose
    from wildscan.core.scan import run_scan
    from wildscan.core.sensors import SensorConfig

    backend = _ground_backend()
    before = CLOCK.reading()
    backend.cast(np.array([0.0, 0.0, 5.0]), np.array([[0.0, 0.0, -1.0]]), 10.0)
    alone = CLOCK.reading() - before
    assert alone.cast > 0 and alone.scans == 0 and alone.cast_in_scans == 0

    before = CLOCK.reading()
    run_scan(backend, Pose(0.0, 0.0, 0.0), SensorConfig(rh_deg=5.0))
    scan = CLOCK.reading() - before
    # placement and sweep cast inside the scan; the scan does more than cast
    assert 0 < scan.cast_in_scans == scan.cast < scan.scans


def test_a_scan_inside_a_scan_is_counted_once():
    before = CLOCK.reading()
    with CLOCK.scan():
        with CLOCK.scan():
            with CLOCK.casting():
                pass
    spent = CLOCK.reading() - before
    assert spent.scans > 0 and spent.cast_in_scans == spent.cast > 0
    assert spent.scans < 1.0  # one scan's seconds, not two nested ones added


def test_the_printed_line_gives_the_share_and_the_ratio():
    assert cast_share_line(Reading(cast=3.0, scans=4.0, cast_in_scans=2.0)) == (
        "cast 2.00 s of 4.00 s in scans (50 %), scan/cast 2.00x"
    )
    assert cast_share_line(Reading(cast=1.5)) == "cast 1.50 s (no scans timed)"


def test_casts_on_parallel_threads_are_counted_once(monkeypatch):
    import types

    from wildscan.core.runtime import cast_clock

    now = [100.0]
    monkeypatch.setattr(cast_clock, "time", types.SimpleNamespace(perf_counter=lambda: now[0]))
    clock = cast_clock.CastClock()
    first, second = clock.casting(), clock.casting()
    first.__enter__()  # at 100: one thread's cast begins
    now[0] = 101.0
    second.__enter__()  # another thread's begins while the first runs
    now[0] = 102.0
    first.__exit__(None, None, None)
    now[0] = 103.0
    second.__exit__(None, None, None)
    assert clock.reading().cast == 3.0  # 100 to 103 with a cast under way; summed, it would be 4
