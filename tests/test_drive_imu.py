"""`wildscan drive`'s IMU and revisits end to end: the integrated gyro follows the trajectory's
yaw (the issue's bar), +g at rest, calib.txt's extrinsics, revisits.json recomputed from
poses.txt and the TUM file."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from wildscan.app.drive import DriveRequest, run_drive
from wildscan.core.io.imu_csv import read_imu_csv
from wildscan.core.io.tum import read_tum
from wildscan.core.motion.imu import GRAVITY
from wildscan.core.sensor import SensorConfig

from tests.helpers.dataset_helpers import read_kitti_calib
from tests.helpers.imu_helpers import integrated_yaw, mount_rotation, quaternion_matrices

pytestmark = pytest.mark.slow  # a world and a drive each: `make test` runs them, `make test-fast` not


def test_the_integrated_gyro_follows_the_trails_yaw_within_2_degrees_over_60_s(tmp_path):
    """The issue's bar on today's `--trail` drive (seed 1, default detail), noise off: 14 3D
    scans at 1 m/s are 63 s; over the first 60 s the gyro's yaw stays within 2 deg of the
    trajectory's (it is within 0.001 deg: the readings are exact derivatives)."""
    out = tmp_path / "drive"
    request = DriveRequest(out=str(out), seed=1, trail=True, scans=14, imu_noise="off", bag="none")
    report = run_drive(request, say=lambda text: None)
    assert report.duration >= 60
    times, gyro_yaw, tum_yaw = integrated_yaw(out)
    first = times <= 60.0
    error = np.degrees(np.abs(gyro_yaw - tum_yaw))[first]
    assert first.sum() == 2401 and np.degrees(np.ptp(tum_yaw[first])) > 30  # the trail turns
    assert error.max() < 2.0, error.max()
    assert error.max() < 0.01  # the margin the exact readings leave
    calib = read_kitti_calib(out / "sequences" / "00" / "calib.txt")
    assert np.allclose(calib["Tr_imu_to_velo"][:3, 3], [-0.15, 0.0, 0.35 - 0.723])  # sensor frame
    # the same drive with the tactical-grade IMU's datasheet errors: it drifts, by less than
    # the bar (0.8 deg/h of bias, 0.09 deg/sqrt(h) of noise), and the noise is really there
    noisy = tmp_path / "adis"
    run_drive(replace(request, out=str(noisy), imu="adis16495", imu_noise="on"), say=lambda text: None)
    times, gyro_yaw, tum_yaw = integrated_yaw(noisy)
    drift = np.degrees(np.abs(gyro_yaw - tum_yaw))[times <= 60.0]
    assert error.max() * 10 < drift.max() < 2.0, drift.max()


def low_trail_drive(out, **settings):
    """Seed 1's low-detail trail at r_h = 6 deg (30 2D scans a 3D scan), no bags."""
    request = DriveRequest(
        out=str(out),
        seed=1,
        detail="low",
        trail=True,
        sensor=SensorConfig(rh_deg=6.0),
        bag="none",
        **settings,
    )
    return run_drive(request, say=lambda text: None)


def test_standing_still_the_accelerometer_reads_g_up_and_the_gyro_zero(tmp_path):
    """--speed 0 on seed 1's trail start: every sample is +g along the world's up, in the IMU's
    (tilted) axes, with the BMI088's noise off."""
    out = tmp_path / "still"
    low_trail_drive(out, speed=0.0, imu_noise="off")
    stamps, gyro, accel = read_imu_csv((out / "imu.csv").read_text())
    tum = read_tum((out / "trajectory.tum").read_text())
    imu_to_world = quaternion_matrices(tum[:1, 4:])[0] @ mount_rotation(out)
    up = imu_to_world.T @ [0.0, 0.0, GRAVITY]
    assert len(stamps) == 150 and np.all(gyro == 0)
    assert np.allclose(accel, up, atol=1e-8) and np.allclose(
        np.linalg.norm(accel, axis=1), GRAVITY, atol=1e-8
    )
    assert accel[0, 2] > 0.9 * GRAVITY


def test_revisits_of_a_drive_are_every_pair_within_3_m_recomputed_from_poses_and_tum(tmp_path):
    """A drive at 2 m/s, 0.75 s (1.5 m) a 3D scan, has neighbours within 3 m: revisits.json
    lists exactly the pairs poses.txt puts within 3 m, with the TUM file's time between them,
    and for each scan the count of scans beyond 25 m."""
    out = tmp_path / "slow"
    report = low_trail_drive(out, speed=2.0, imu="none")
    assert not (out / "imu.csv").exists()
    poses = np.loadtxt(out / "sequences" / "00" / "poses.txt").reshape(-1, 3, 4)
    xy = poses[:, :2, 3]
    distance = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    doc = json.loads((out / "revisits.json").read_text())
    assert (
        doc["positive_radius_m"] == 3.0
        and doc["negative_radius_m"] == 25.0
        and "Wild-Places" in doc["source"]
    )
    seq = doc["sequences"]["00"]
    assert seq["scans"] == report.scans_3d == len(poses) > 30
    assert seq["columns"] == ["scan_a", "scan_b", "distance_m", "time_apart_s"]
    listed = {(a, b) for a, b, _, _ in seq["positives"]}
    expected = {(a, b) for a, b in zip(*np.nonzero(distance <= 3.0)) if a < b}
    assert listed == expected and len(listed) >= report.scans_3d - 1
    tum = read_tum((out / "trajectory.tum").read_text())
    starts = tum[::30, 0]  # each 3D scan's first 2D scan
    for a, b, d, dt in seq["positives"]:
        assert d <= 3.0 and abs(d - distance[a, b]) < 1e-6
        assert abs(d - np.hypot(*(tum[30 * a, 1:3] - tum[30 * b, 1:3]))) < 1e-6
        assert abs(dt - (starts[b] - starts[a])) < 1e-6
    assert seq["negatives_per_scan"] == (distance > 25.0).sum(axis=1).tolist()


def test_between_the_scans_poses_the_imus_curve_stays_on_the_sweeps_line():
    """The IMU's C2 curve and the sweep's straight lines meet at every 2D scan's pose; in
    between, on seed 1's trail (default detail, 18 s), the optical centre on the curve is
    within 0.5 mm of the line at the 99th percentile and within 2 cm anywhere (the largest
    gaps where the placement jumps from one 2D scan to the next)."""
    from wildscan.app.drive.world import drive_path, drive_world
    from wildscan.app.scan import crop_radius
    from wildscan.core.motion.imu import ImuMount, imu_truth, sample_stamps
    from wildscan.core.motion.placements import place_all
    from wildscan.core.motion.trajectory import instants, schedule
    from wildscan.raycast.select import make_backend

    request = DriveRequest(out="unused", seed=1, trail=True, scans=4)
    world = drive_world(request)
    path, sensor = drive_path(request, world.trail), request.sensor
    plan = schedule(path, request.speed, sensor.sweeps, request.scans)
    times, xy, yaw = instants(path, request.speed, plan.scans_2d + 1)
    backend = make_backend("auto", geometry=world.crop(xy, crop_radius(sensor)), notify=None)
    motion = place_all(backend, times, xy, yaw, request.speed * times)
    period = sensor.device.timing.column_period_ns
    stamps = sample_stamps(plan.scans_2d * period, 1000)
    centre = imu_truth(motion, stamps, period, ImuMount((0.0, 0.0, 0.723), np.eye(3))).position
    k, s = stamps // period, (stamps % period / period)[:, None]
    gap = np.linalg.norm(centre - (motion.centre[k] * (1 - s) + motion.centre[k + 1] * s), axis=1)
    assert np.all(gap[stamps % period == 0] < 1e-9)
    assert np.percentile(gap, 99) < 5e-4 and gap.max() < 0.02, (np.percentile(gap, 99), gap.max())
