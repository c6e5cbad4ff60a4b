"""The drive's per-2D-scan messages serialized many at once (core/io/rosbag_layout.py) are the
bytes rosbags writes one message at a time: two bags, one written each way, are the same file."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.io.rosbag import BASE_LINK, LASER, ODOM, DriveBag


def folder(path):
    """`path`/bag, `path` made: both bags of a test are named alike (a ROS 2 bag names its files
    after its folder)."""
    path.mkdir()
    return path / "bag"


def scan_values(count: int, beams: int):
    rng = np.random.default_rng(11)
    stamps = (np.arange(count) + 3) * 25_000_000 + 10**9 - 50_000_000  # crosses a whole second
    translations = rng.normal(0, 100, (count, 2, 3))
    rotations = rng.normal(0, 1, (count, 2, 4))
    odometry = tuple(rng.normal(0, 5, (count, n)) for n in (3, 4, 3, 3))
    ranges = rng.uniform(0.1, 30, (count, beams))
    ranges[0, :3] = (np.inf, -np.inf, 0.0)
    intensities = rng.uniform(0, 1, (count, beams))
    geometry = {
        "angle_min": -2.356,
        "angle_max": 2.356,
        "angle_increment": 0.00436,
        "time_increment": 1.7e-5,
        "scan_time": 0.025,
        "range_min": 0.1,
        "range_max": 30.0,
    }
    return stamps, translations, rotations, odometry, geometry, ranges, intensities


@pytest.mark.parametrize("flavour, storage", [("ros1", "mcap"), ("ros2", "mcap"), ("ros2", "sqlite3")])
def test_many_at_once_writes_the_bytes_of_one_at_a_time(tmp_path, flavour, storage):
    stamps, translations, rotations, odometry, geometry, ranges, intensities = scan_values(7, 13)
    frames = [(ODOM, BASE_LINK), (BASE_LINK, LASER)]
    with DriveBag(folder(tmp_path / "one"), flavour, storage) as bag:
        for row, stamp in enumerate(stamps.tolist()):
            bag.tf(
                stamp, [(p, c, translations[row, i], rotations[row, i]) for i, (p, c) in enumerate(frames)]
            )
            bag.odometry(stamp, *(part[row] for part in odometry))
            bag.laser_scan(stamp, geometry, ranges[row], intensities[row])
    with DriveBag(folder(tmp_path / "many"), flavour, storage) as bag:
        bag.scans(
            stamps[:3],
            frames,
            (translations[:3], rotations[:3]),
            tuple(p[:3] for p in odometry),
            geometry,
            (ranges[:3], intensities[:3]),
        )
        bag.scans(
            stamps[3:],
            frames,
            (translations[3:], rotations[3:]),
            tuple(p[3:] for p in odometry),
            geometry,
            (ranges[3:], intensities[3:]),
        )
        counts = dict(bag.counts)
    assert counts["/tf"] == counts["/odom"] == counts["/laser2D"] == 7
    assert bag_bytes(tmp_path / "one") == bag_bytes(tmp_path / "many")


def bag_bytes(folder) -> dict:
    """Every file of the bag written into `folder`/bag, by its path there."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_tf_of_the_base_alone_and_odometry_without_laser_scans(tmp_path):
    """A multi-beam lidar's bags: tf with one transform, no LaserScan."""
    stamps, translations, rotations, odometry, *_ = scan_values(4, 5)
    with DriveBag(folder(tmp_path / "one"), "ros1") as bag:
        for row, stamp in enumerate(stamps.tolist()):
            bag.tf(stamp, [(ODOM, BASE_LINK, translations[row, 0], rotations[row, 0])])
            bag.odometry(stamp, *(part[row] for part in odometry))
    with DriveBag(folder(tmp_path / "many"), "ros1") as bag:
        bag.scans(stamps, [(ODOM, BASE_LINK)], (translations[:, :1], rotations[:, :1]), odometry, None, None)
    assert bag_bytes(tmp_path / "one") == bag_bytes(tmp_path / "many")


@pytest.mark.parametrize("flavour", ["ros1", "ros2"])
def test_imu_messages_many_at_once_interleaved_in_time_are_the_bytes_of_one_at_a_time(tmp_path, flavour):
    """sensor_msgs/Imu laid out by rosbag_layout.imu_layout and written among the 2D scans'
    messages (before a 2D scan those earlier than it, after it those of its stamp or later)
    are the bytes rosbags writes message by message in that order."""
    stamps, translations, rotations, odometry, *_ = scan_values(4, 5)
    rng = np.random.default_rng(3)
    imu_stamps = np.sort(np.concatenate([stamps[:2], stamps[1:] - 5_000_000, stamps[-1:] + 7_000_000]))
    n = len(imu_stamps)
    orientation, gyro, accel = rng.normal(0, 1, (n, 4)), rng.normal(0, 1, (n, 3)), rng.normal(0, 9, (n, 3))
    covariances = tuple(rng.uniform(0, 1, (n, 9)) for _ in range(3))
    frames = [(ODOM, BASE_LINK)]
    with DriveBag(folder(tmp_path / "one"), flavour, imu=True) as bag:
        done = 0
        for row, stamp in enumerate(stamps.tolist()):
            while done < n and imu_stamps[done] < stamp:
                bag.imu(
                    int(imu_stamps[done]),
                    orientation[done],
                    gyro[done],
                    accel[done],
                    [c[done] for c in covariances],
                )
                done += 1
            bag.tf(stamp, [(ODOM, BASE_LINK, translations[row, 0], rotations[row, 0])])
            bag.odometry(stamp, *(part[row] for part in odometry))
        for i in range(done, n):
            bag.imu(int(imu_stamps[i]), orientation[i], gyro[i], accel[i], [c[i] for c in covariances])
        counts = dict(bag.counts)
    with DriveBag(folder(tmp_path / "many"), flavour, imu=True) as bag:
        tf = (translations[:, :1], rotations[:, :1])
        bag.scans(
            stamps, frames, tf, odometry, None, None, (imu_stamps, orientation, gyro, accel, covariances)
        )
    assert counts["/imu"] == n == 6 and counts["/tf"] == 4
    assert bag_bytes(tmp_path / "one") == bag_bytes(tmp_path / "many")
