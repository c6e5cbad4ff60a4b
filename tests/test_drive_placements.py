"""A drive stands the robot at every 2D scan with `stand`'s arithmetic batched
(core/motion/placements.py `stand_all`): the same placement, bit for bit, as `stand` gives
one pose at a time, and the poses it cannot place are left to `stand` to reject."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.errors import PoseRejected
from wildscan.core.motion.placements import stand_all
from wildscan.core.placement import (
    LASER_CLEARANCE,
    Pose,
    cast_lasers_many,
    lasers_of,
    probe_ground_z_many,
    stand,
)
from wildscan.core.world import plan_world
from wildscan.raycast.from_plan import plan_geometry
from wildscan.raycast.select import make_backend


@pytest.fixture(scope="module")
def hills():
    plan = plan_world(2, "low")
    return make_backend("embree", geometry=plan_geometry(plan), notify=None)


def test_the_batch_stands_every_pose_as_stand_does(hills):
    rng = np.random.default_rng(8)
    xy = rng.uniform(-60, 60, (400, 2))
    poses = [Pose(float(x), float(y), float(yaw)) for (x, y), yaw in zip(xy, rng.uniform(-180, 180, 400))]
    z_start = probe_ground_z_many(hills, xy) + LASER_CLEARANCE
    on_world = np.isfinite(z_start)
    poses, z_start = [p for p, ok in zip(poses, on_world) if ok], z_start[on_world]
    rows = cast_lasers_many(hills, poses, z_start)
    stood = stand_all(poses, rows)
    placed = rejected = 0
    for i, (pose, row) in enumerate(zip(poses, rows)):
        try:
            one = stand(pose, float(z_start[i]), lasers_of(pose, row))
        except PoseRejected:
            assert not stood.fits[i]
            rejected += 1
            continue
        assert stood.fits[i]
        placed += 1
        many = stood.placement(i, pose, lasers_of(pose, row))
        assert many.optical_centre.tobytes() == one.optical_centre.tobytes()
        assert many.ground_centre.tobytes() == one.ground_centre.tobytes()
        assert (many.roll_rad, many.pitch_rad) == (one.roll_rad, one.pitch_rad)
        assert stood.rotation[i].tobytes() == one.rotation.tobytes()
    assert placed > 100 and rejected > 5  # slopes and trees: both kinds seen
