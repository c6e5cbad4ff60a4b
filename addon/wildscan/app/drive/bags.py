"""A drive's ROS bags (core/io/rosbag.py writes them): what goes on each topic, from the
robot's motion and the sweeps."""

from __future__ import annotations

from contextlib import ExitStack

import numpy as np

from ...core import detmath as dm
from ...core.io.rosbag import BASE_LINK, LASER, ODOM, SENSOR, DriveBag, point_records
from ...core.leveling import rot_z
from ...core.motion.placements import Motion
from ...core.motion.rotations import quaternions
from ...core.motion.sweep import Sweep
from ...core.motion.timing import BEAM_INTERVAL, SCAN_PERIOD
from ...core.placement import COLUMN_HEIGHT
from ...core.sensor import BEAMS_PER_2D_SCAN, FIRST_BEAM_DEG, R_V_DEG, SensorConfig

BAG_NAMES = {"ros1": "drive.bag", "ros2": "drive_ros2"}
NS_PER_SCAN = 25_000_000  # SCAN_PERIOD in nanoseconds, kept whole so stamps are exact
# The laser frame's axes in the head's frame: its x along the column (beam 540, straight up),
# its y along the head's X arm, so beam n lies at LaserScan angle n * r_v - 135 deg.
LASER_AXES = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
IDENTITY_Q = (0.0, 0.0, 0.0, 1.0)

assert abs(NS_PER_SCAN * 1e-9 - SCAN_PERIOD) < 1e-15


def open_bags(stack: ExitStack, stage, flavours, ros2_storage: str) -> list[DriveBag]:
    """The bags asked for, open in the staging folder, closed by `stack`."""
    return [
        stack.enter_context(DriveBag(stage.path(BAG_NAMES[flavour]), flavour, ros2_storage))
        for flavour in flavours
    ]


def scan_geometry(sensor: SensorConfig) -> dict:
    """LaserScan's description of the UTM-30LX-EW's 2D scan."""
    inc = dm.radians(R_V_DEG)
    return {
        "angle_min": dm.radians(FIRST_BEAM_DEG),
        "angle_max": dm.radians(FIRST_BEAM_DEG) + (BEAMS_PER_2D_SCAN - 1) * inc,
        "angle_increment": inc,
        "time_increment": BEAM_INTERVAL,
        "scan_time": SCAN_PERIOD,
        "range_min": sensor.min_range,
        "range_max": sensor.max_range,
    }


class BagFeed:
    """Everything the bags say about a drive, precomputed once for all its 2D scans."""

    def __init__(self, bags: list[DriveBag], motion: Motion, sensor: SensorConfig):
        self.bags = bags
        self.motion = motion
        self.sensor = sensor
        self.geometry = scan_geometry(sensor)
        self.q_base = quaternions(motion.rotation)
        count = len(motion.times) - 1
        head = dm.deg2rad(np.arange(count) * sensor.rh_deg)  # the head at the start of each 2D scan
        self.q_laser = quaternions(dm.matmul(np.stack([rot_z(float(a)) for a in head]), LASER_AXES))
        ground = motion.ground
        to_base = np.swapaxes(motion.rotation[:-1], 1, 2)  # R_k^T: the velocity in base_link
        self.linear = dm.apply(to_base, ground[1:] - ground[:-1]) / SCAN_PERIOD
        self.angular = motion.step / SCAN_PERIOD

    def static(self) -> None:
        for bag in self.bags:
            bag.tf(0, [(BASE_LINK, SENSOR, (0.0, 0.0, COLUMN_HEIGHT), IDENTITY_Q)], static=True)

    def scans(self, result: Sweep) -> None:
        """tf, odometry and LaserScan of each 2D scan of a sweep, in time order."""
        returns = result.returns
        ranges = np.where(returns.keep, returns.range, np.inf)
        ranges[~returns.keep & np.isfinite(returns.range) & (returns.range < self.sensor.min_range)] = -np.inf
        intensities = np.where(returns.keep, returns.intensity, 0.0)
        for row, k in enumerate(range(result.k0, result.k1)):
            stamp = k * NS_PER_SCAN
            beams = slice(row * BEAMS_PER_2D_SCAN, (row + 1) * BEAMS_PER_2D_SCAN)
            base = (ODOM, BASE_LINK, self.motion.ground[k], self.q_base[k])
            laser = (BASE_LINK, LASER, (0.0, 0.0, COLUMN_HEIGHT), self.q_laser[k])
            for bag in self.bags:
                bag.tf(stamp, [base, laser])
                bag.odometry(stamp, self.motion.ground[k], self.q_base[k], self.linear[k], self.angular[k])
                bag.laser_scan(stamp, self.geometry, ranges[beams], intensities[beams])

    def clouds(self, result: Sweep) -> None:
        """The raw and the deskewed cloud of a 3D scan, stamped at its first beam and recorded
        when its last 2D scan ends."""
        stamp, recorded = result.k0 * NS_PER_SCAN, result.k1 * NS_PER_SCAN
        for topic, cloud in (("/points", result.raw), ("/points_deskewed", result.deskewed)):
            records = point_records(
                cloud.xyz, cloud.intensity, cloud.ring, cloud.extra["time"], cloud.label, cloud.instance
            )
            for bag in self.bags:
                bag.points(topic, stamp, recorded, records)

    def counts(self) -> dict[str, dict[str, int]]:
        return {bag.flavour: dict(bag.counts) for bag in self.bags}
