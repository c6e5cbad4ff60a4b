"""A drive's length is limited by the memory it really holds per column (held-out defect 6
of issue 31): a spinning lidar's firing cycles are counted as such, the VLP-16's 80 s along
the trail (1,452,381 firing cycles, once refused as "2D scans; at most 100,000") fits, and
placing the robot keeps a few arrays per instant, not a Python object."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from wildscan.core.errors import UserError
from wildscan.core.motion import placements, trajectory
from wildscan.core.sensors import device_named
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.select import make_backend


def flat_ground():
    tris = [[[-500, -50, 0], [500, -50, 0], [500, 50, 0]], [[-500, -50, 0], [500, 50, 0], [-500, 50, 0]]]
    return make_backend("auto", geometry=from_triangles(np.array(tris, float), [1, 1], [1, 1]), notify=None)


def test_the_vlp16_drive_of_80_s_fits_and_the_limit_is_in_its_own_terms():
    vlp = device_named("vlp16")
    period = vlp.timing.column_period_s
    trail = trajectory.straight_path(0, 0, 0, 1_452_381 * period)  # seed 1's trail at 1 m/s: 80.3 s
    plan = trajectory.schedule(trail, 1.0, 1809, None, period, vlp.columns_named)
    assert plan.scans_2d == 1_452_381 and plan.scans_2d <= trajectory.MAX_COLUMNS
    too_long = trajectory.straight_path(0, 0, 0, 1000.0)
    with pytest.raises(UserError) as e:
        trajectory.schedule(too_long, 1.0, 1809, None, period, vlp.columns_named)
    said = str(e.value)
    assert "18,084,490 firing cycles of the VLP-16 (1,000 s)" in said and "2D scans" not in said
    assert f"{trajectory.MAX_COLUMNS:,} ({trajectory.MAX_COLUMNS * period:,.0f} s of this device)" in said
    assert "2D scans of the UTM-30LX-EW" == device_named("utm30lx-ew").columns_named


@pytest.mark.slow  # 20,000 placements: about 10 s
def test_placing_a_drive_keeps_arrays_not_an_object_per_instant():
    backend = flat_ground()
    count = 20_000
    times = np.arange(count) * 0.001
    xy = np.column_stack([times, np.zeros(count)])
    tracemalloc.start()
    motion = placements.place_all(backend, times, xy, np.zeros(count), times, keep=range(0, count, 1000))
    held, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert held / count < 400, held / count  # was 2,200 B: a Placement, its Pose and lasers each
    assert sorted(motion.kept) == list(range(0, count, 1000))
    assert motion.placement(5000).pose.x == pytest.approx(5.0)
    np.testing.assert_allclose(motion.centre[:, 2], motion.centre[0, 2])
    np.testing.assert_array_equal(motion.centre[5000], motion.placement(5000).optical_centre)
