"""The drive's IMU (core/motion/imu.py, imu_models.py, core/io/imu_csv.py): exact readings
checked against finite differences of the curve they come from, +g at rest, the knots kept,
datasheet noise levels, the same bytes from the same seed, and the CSV read back."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from wildscan.core.errors import UserError
from wildscan.core.io.imu_csv import HEADER, imu_csv_text, read_imu_csv
from wildscan.core.motion.imu import GRAVITY, ImuMount, imu_truth, sample_stamps
from wildscan.core.motion.imu_models import ADIS16495, BMI088, check_rate, with_errors
from wildscan.core.motion.placements import motion_of, sensor_to_world_matrices
from wildscan.core.placement import Placement, Pose
from wildscan.core.spatial.rotations import log_map

PERIOD_NS = 25_000_000  # the UTM-30LX-EW's 2D scan
K = 200  # knots - 1: 5 s
# a mount with a lever arm and turned axes, so both show in the readings
MOUNT = ImuMount((-0.15, 0.05, 0.35), np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))


def synthetic_motion(still: bool = False, roll=0.05, pitch=0.08):
    """A drive's knots (every 25 ms) on a smooth wavy path with yaw, pitch and roll swinging."""
    t = np.arange(K + 1) * 0.025
    w = 0.0 if still else 1.0
    yaw = 30 + 40 * np.sin(t * 0.7 * w)
    pitches = pitch * np.sin(t * 1.3 * w + 0.4)
    rolls = roll * np.cos(t * 2.1 * w)
    ground = np.column_stack([3 * np.cos(t * w), 2 * np.sin(t * 0.5 * w), 0.2 * np.sin(t * 3 * w)])
    placements = [
        Placement(Pose(float(g[0]), float(g[1]), float(y)), g + [0, 0, 0.723], g, float(r), float(p))
        for g, y, r, p in zip(ground, yaw, rolls, pitches)
    ]
    return motion_of(placements, t, t)


def test_gyro_and_accelerometer_are_the_exact_derivatives_of_the_imus_own_pose():
    """Finite differences of the IMU's pose (its rotation and origin, which the lever arm and
    the mount's turn enter) agree with the analytic readings to rounding: central
    differences +-20 us on a curve whose readings reach 0.5 rad/s and 11 m/s^2."""
    motion = synthetic_motion()
    stamps = sample_stamps(K * PERIOD_NS, 200)[10:-10]
    d = 20_000  # ns
    before = imu_truth(motion, stamps - d, PERIOD_NS, MOUNT)
    now = imu_truth(motion, stamps, PERIOD_NS, MOUNT)
    after = imu_truth(motion, stamps + d, PERIOD_NS, MOUNT)
    turn = log_map(np.swapaxes(before.rotation, 1, 2) @ after.rotation) / (2 * d * 1e-9)
    assert np.abs(turn - now.gyro).max() < 1e-8 and np.abs(now.gyro).max() > 0.3
    acceleration = (before.position + after.position - 2 * now.position) / (d * 1e-9) ** 2
    force = np.einsum("nji,nj->ni", now.rotation, acceleration + [0.0, 0.0, GRAVITY])
    assert np.abs(force - now.accel).max() < 1e-3 and np.abs(now.accel - [0, 0, GRAVITY]).max() > 1.0


def test_the_curve_passes_through_every_knot_the_scans_use_and_keeps_close_between():
    """At a knot the IMU's attitude is the placement's exactly; between knots its origin is
    within 0.5 mm of the sweep's straight line between the knots' IMU origins (at up to 3 m/s
    on a wavy path)."""
    motion = synthetic_motion()
    stamps = sample_stamps(K * PERIOD_NS, 1000)
    truth = imu_truth(motion, stamps, PERIOD_NS, MOUNT)
    at_knots = stamps % PERIOD_NS == 0
    k = stamps[at_knots] // PERIOD_NS
    assert np.array_equal(truth.rotation[at_knots], motion.rotation[k] @ MOUNT.rotation)
    knot_origin = motion.ground + np.einsum("nij,j->ni", motion.rotation, MOUNT.translation)
    assert np.abs(truth.position[at_knots] - knot_origin[k]).max() < 1e-12
    s = (stamps % PERIOD_NS / PERIOD_NS)[:, None]
    k_all = stamps // PERIOD_NS
    line = knot_origin[k_all] * (1 - s) + knot_origin[k_all + 1] * s
    assert np.abs(truth.position - line).max() < 5e-4


def test_at_rest_the_accelerometer_reads_g_up_and_the_gyro_nothing():
    flat = imu_truth(
        synthetic_motion(still=True, roll=0.0, pitch=0.0), sample_stamps(10**9, 200), PERIOD_NS, MOUNT
    )
    assert np.allclose(flat.accel, [0.0, 0.0, GRAVITY], atol=1e-12) and np.all(flat.gyro == 0)
    tilted = synthetic_motion(still=True, roll=0.1, pitch=-0.2)
    truth = imu_truth(tilted, sample_stamps(10**9, 200), PERIOD_NS, MOUNT)
    up = np.einsum("nji,j->ni", truth.rotation, [0.0, 0.0, GRAVITY])  # +g up, in the IMU's axes
    assert np.allclose(truth.accel, up, atol=1e-12) and abs(np.linalg.norm(truth.accel[0]) - GRAVITY) < 1e-12
    assert truth.accel[0, 2] < GRAVITY - 0.05  # the tilt shows


def test_sample_stamps_are_whole_nanoseconds_at_the_rate_within_the_drive():
    stamps = sample_stamps(1_650_000_000, 200)
    assert len(stamps) == 330 and stamps[1] == 5_000_000 and stamps[-1] == 1_645_000_000
    assert len(sample_stamps(10**9, 3)) == 3 and sample_stamps(10**9, 3)[1] == 333_333_333


@pytest.mark.parametrize("model", [BMI088, ADIS16495], ids=lambda m: m.name)
def test_white_noise_and_biases_have_the_datasheets_size_and_the_seed_fixes_them(model):
    n, rate = 200_000, 200
    zero = np.zeros((n, 3))
    gyro, accel = with_errors(zero, zero + [0, 0, GRAVITY], rate, model, seed=5)
    again = with_errors(zero, zero + [0, 0, GRAVITY], rate, model, seed=5)
    other = with_errors(zero, zero + [0, 0, GRAVITY], rate, model, seed=6)
    assert np.array_equal(gyro, again[0]) and np.array_equal(accel, again[1])
    assert not np.array_equal(gyro, other[0])
    sigma_g, sigma_a = model.white_sigmas(rate)
    # sample-to-sample differences remove the slow biases: their spread is sqrt(2) sigma
    assert abs(np.diff(gyro, axis=0).std() / math.sqrt(2) / sigma_g - 1) < 0.02
    assert abs(np.diff(accel, axis=0).std() / math.sqrt(2) / sigma_a - 1) < 0.02
    # the mean over the 1000 s is the turn-on bias plus the walk: of the datasheet's order
    bias = np.abs(gyro.mean(axis=0))
    assert np.all(bias < 5 * (model.gyro_turn_on + model.gyro_stability))


def test_noise_densities_are_the_datasheet_figures_in_si_units():
    assert math.isclose(BMI088.gyro_noise, math.radians(0.014))  # 0.014 deg/s/sqrt(Hz)
    assert math.isclose(BMI088.accel_noise, 175e-6 * 9.80665)  # 175 ug/sqrt(Hz)
    assert math.isclose(ADIS16495.gyro_noise, math.radians(0.09) / 60)  # 0.09 deg/sqrt(h)
    assert math.isclose(ADIS16495.gyro_stability, math.radians(0.8) / 3600)  # 0.8 deg/h
    assert ADIS16495.gyro_noise < BMI088.gyro_noise / 5  # tactical grade beats consumer


@pytest.mark.parametrize("rate", [0, 2001, 2.5, True])
def test_a_rate_out_of_range_is_a_user_mistake_naming_the_setting(rate):
    with pytest.raises(UserError) as e:
        check_rate(rate)
    assert e.value.setting == "imu_rate" and "2000" in e.value.message


def test_imu_csv_reads_back_with_pythons_csv_and_numpy_as_euroc_columns():
    stamps = np.array([0, 5_000_000, 10_000_000], dtype=np.int64)
    gyro = np.array([[0.1, -0.2, 0.3], [1e-9, 0.0, -1.0], [0.0, 0.0, 0.0]])
    accel = np.array([[0.0, 0.0, GRAVITY], [1.5, -2.5, 9.0], [0.0, 0.0, 9.8]])
    text = imu_csv_text(stamps, gyro, accel)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[0] == HEADER.split(",") and rows[0][0] == "#timestamp [ns]" and len(rows[0]) == 7
    assert all(len(r) == 7 for r in rows) and [int(r[0]) for r in rows[1:]] == stamps.tolist()
    table = np.loadtxt(io.StringIO(text), delimiter=",", comments="#")
    assert np.allclose(table[:, 1:4], gyro, atol=1e-12) and np.allclose(table[:, 4:], accel, atol=1e-9)
    back = read_imu_csv(text)
    assert np.array_equal(back[0], stamps) and np.allclose(back[1], gyro, atol=1e-12)


def test_the_mount_turns_readings_into_the_imus_axes():
    """An IMU turned 90 deg about z reads base_link's x motion on its -y axis: the same
    drive, two mounts, readings related by the mount's rotation."""
    motion = synthetic_motion()
    stamps = sample_stamps(K * PERIOD_NS, 200)
    aligned = imu_truth(motion, stamps, PERIOD_NS, ImuMount(MOUNT.translation, np.eye(3)))
    turned = imu_truth(motion, stamps, PERIOD_NS, MOUNT)
    assert np.allclose(turned.gyro, aligned.gyro @ MOUNT.rotation, atol=1e-12)
    assert np.allclose(turned.accel, aligned.accel @ MOUNT.rotation, atol=1e-12)
    assert np.allclose(sensor_to_world_matrices(np.zeros(1), np.zeros(1), np.zeros(1))[0], np.eye(3))


def test_readings_are_the_same_bits_whatever_the_chunks(monkeypatch):
    """A drive of kilometres is evaluated CHUNK samples at a time: each sample's own numbers."""
    from wildscan.core.motion import imu

    motion, stamps = synthetic_motion(), sample_stamps(K * PERIOD_NS, 1000)
    whole = imu_truth(motion, stamps, PERIOD_NS, MOUNT)
    monkeypatch.setattr(imu, "CHUNK", 333)
    chunked = imu_truth(motion, stamps, PERIOD_NS, MOUNT)
    for name in ("stamps_ns", "position", "rotation", "gyro", "accel"):
        assert np.array_equal(getattr(whole, name), getattr(chunked, name)), name
