"""A drive's ROS bags (core/io/rosbag.py writes them): what goes on each topic, from the
robot's motion and the sweeps. The LaserScan geometry, stamps and rates are the sensor's
device's (core/sensors): a planar fan's first angle, step, beam count and timing."""

from __future__ import annotations

from contextlib import ExitStack

import numpy as np

from ...core import detmath as dm
from ...core.errors import UserError
from ...core.io.rosbag import BASE_LINK, IMU, LASER, ODOM, SENSOR, DriveBag, point_records
from ...core.motion.placements import Motion
from ...core.motion.sweep import Sweep
from ...core.placement import COLUMN_HEIGHT
from ...core.sensors import SensorConfig
from ...core.sensors.device import Device
from ...core.spatial.leveling import rot_z
from ...core.spatial.rotations import quaternions

BAG_NAMES = {"ros1": "drive.bag", "ros2": "drive_ros2"}
# The laser frame's axes in the head's frame: its x along the column (beam 540, straight up),
# its y along the head's X arm, so beam n lies at LaserScan angle n * r_v - 135 deg.
LASER_AXES = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
IDENTITY_Q = (0.0, 0.0, 0.0, 1.0)


def open_bags(stack: ExitStack, stage, flavours, ros2_storage: str, imu: bool = False) -> list[DriveBag]:
    """The bags asked for, open in the staging folder, closed by `stack`."""
    return [
        stack.enter_context(DriveBag(stage.path(BAG_NAMES[flavour]), flavour, ros2_storage, imu))
        for flavour in flavours
    ]


def scan_geometry(sensor: SensorConfig) -> dict:
    """LaserScan's description of a 2D scan: the device's planar fan (the UTM-30LX-EW's)."""
    device = sensor.device
    first, step = _fan(device)
    inc = dm.radians(step)
    return {
        "angle_min": dm.radians(first),
        "angle_max": dm.radians(first) + (device.beams.count - 1) * inc,
        "angle_increment": inc,
        "time_increment": device.timing.step_interval_s,
        "scan_time": device.timing.column_period_s,
        "range_min": sensor.min_range,
        "range_max": sensor.max_range,
    }


def is_2d_scanner(device: Device) -> bool:
    """A planar fan (the UTM-30LX-EW): each column is one LaserScan."""
    return device.beams.fan is not None and device.beams.planar


def _fan(device: Device) -> tuple[float, float]:
    """(first, step) degrees of a device whose column is one LaserScan: a planar fan."""
    if device.beams.fan is None or not device.beams.planar:
        raise UserError(f"{device.id} is not a 2D scanner (a planar fan): its columns are no LaserScan")
    return device.beams.fan


class BagFeed:
    """Everything the bags say about a drive, precomputed once for all its 2D scans."""

    def __init__(self, bags: list[DriveBag], motion: Motion, sensor: SensorConfig, imu=None):
        self.bags = bags
        self.motion = motion
        self.sensor = sensor
        self.imu = imu  # app/drive/imu.py DriveImu, or None
        # a 2D scanner's columns are LaserScans on a turning laser frame; a multi-beam lidar's
        # are not (its bags carry tf, odometry and the PointCloud2s only)
        self.geometry = scan_geometry(sensor) if bags and is_2d_scanner(sensor.device) else None
        timing = sensor.device.timing
        self.ns_per_scan = timing.column_period_ns  # kept whole so stamps are exact
        self.per_column = sensor.device.beams.count
        self.q_base = quaternions(motion.rotation)
        count = len(motion.times) - 1
        head = dm.deg2rad(np.arange(count) * sensor.rh_deg)  # the head at the start of each 2D scan
        if self.geometry is not None:
            self.q_laser = quaternions(dm.matmul(np.stack([rot_z(float(a)) for a in head]), LASER_AXES))
        ground = motion.ground
        to_base = np.swapaxes(motion.rotation[:-1], 1, 2)  # R_k^T: the velocity in base_link
        self.linear = dm.apply(to_base, ground[1:] - ground[:-1]) / timing.column_period_s
        self.angular = motion.step / timing.column_period_s

    def static(self) -> None:
        transforms = [(BASE_LINK, SENSOR, (0.0, 0.0, COLUMN_HEIGHT), IDENTITY_Q)]
        if self.imu is not None:
            transforms.append((BASE_LINK, IMU, *self.imu.static_transform()))
        for bag in self.bags:
            bag.tf(0, transforms, static=True)

    def scans(self, result: Sweep, last: bool = False) -> None:
        """tf, odometry and LaserScan of each 2D scan of a sweep, and the IMU's samples of its
        stretch of time (to the drive's end when `last`), in time order."""
        returns = result.returns
        ranges = np.where(returns.keep, returns.range, np.inf)
        ranges[~returns.keep & np.isfinite(returns.range) & (returns.range < self.sensor.min_range)] = -np.inf
        intensities = np.where(returns.keep, returns.intensity, 0.0)
        ks = np.arange(result.k0, result.k1)
        frames = [(ODOM, BASE_LINK)]
        translations, rotations = [self.motion.ground[ks]], [self.q_base[ks]]
        if self.geometry is not None:
            frames.append((BASE_LINK, LASER))
            translations.append(np.broadcast_to((0.0, 0.0, COLUMN_HEIGHT), (len(ks), 3)))
            rotations.append(self.q_laser[ks])
        poses = (np.stack(translations, axis=1), np.stack(rotations, axis=1))
        odometry = (self.motion.ground[ks], self.q_base[ks], self.linear[ks], self.angular[ks])
        laser = (ranges.reshape(len(ks), -1), intensities.reshape(len(ks), -1))
        imu = None
        if self.imu is not None:
            imu = self.imu.window(result.k0 * self.ns_per_scan, result.k1 * self.ns_per_scan, last)
        for bag in self.bags:
            bag.scans(ks * self.ns_per_scan, frames, poses, odometry, self.geometry, laser, imu)

    def clouds(self, result: Sweep) -> None:
        """The raw and the deskewed cloud of a 3D scan, stamped at its first beam and recorded
        when its last 2D scan ends."""
        stamp, recorded = result.k0 * self.ns_per_scan, result.k1 * self.ns_per_scan
        for topic, cloud in (("/points", result.raw), ("/points_deskewed", result.deskewed)):
            records = point_records(
                cloud.xyz,
                cloud.intensity,
                cloud.ring,
                cloud.extra["time"],
                cloud.label,
                cloud.instance,
                cloud.extra.get("weather"),  # in weather only: a clear drive keeps its bytes
            )
            for bag in self.bags:
                bag.points(topic, stamp, recorded, records)

    def counts(self) -> dict[str, dict[str, int]]:
        return {bag.flavour: dict(bag.counts) for bag in self.bags}
