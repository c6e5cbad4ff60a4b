"""Reading a drive's IMU back as a user would: the gyro integrated from imu.csv against the
TUM trajectory (the issue's bar: `python -c "from tests.helpers.imu_helpers import
yaw_error_deg; print(yaw_error_deg('DIR', 60))"` on a drive with --imu-noise off)."""

from __future__ import annotations

import json

import numpy as np

from wildscan.core.io.imu_csv import read_imu_csv
from wildscan.core.io.tum import read_tum
from wildscan.core.spatial.rotations import matrix


def quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) of unit quaternions (x, y, z, w), (n, 4): the formula, not our code."""
    x, y, z, w = np.asarray(q, dtype=np.float64).T
    rows = [
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ]  # fmt: skip
    return np.stack(rows, axis=-1).reshape(-1, 3, 3)


def mount_rotation(out) -> np.ndarray:
    imu = json.loads((out / "drive.json").read_text())["imu"]
    return quaternion_matrices(np.array([imu["mount"]["quaternion_xyzw"]]))[0]


def integrated_yaw(out) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, yaw from the gyro integrated from the first pose, yaw of the TUM trajectory) at
    the TUM file's instants, radians unwrapped. The gyro is integrated on SO(3) (each step the
    rotation of the mean of its two samples), the IMU frame taken back to the body by the mount."""
    stamps, gyro, _ = read_imu_csv((out / "imu.csv").read_text())
    tum = read_tum((out / "trajectory.tum").read_text())
    mount = mount_rotation(out)
    steps = matrix((gyro[1:] + gyro[:-1]) / 2 * (np.diff(stamps) / 1e9)[:, None])
    attitude = quaternion_matrices(tum[:1, 4:])[0] @ mount
    yaw = [np.arctan2(attitude[1, 0], attitude[0, 0])]
    for step in steps:
        attitude = attitude @ step
        body = attitude @ mount.T
        yaw.append(np.arctan2(body[1, 0], body[0, 0]))
    at = np.searchsorted(stamps, np.round(tum[:, 0] * 1e9).astype(np.int64))
    keep = at < len(stamps)
    truth = quaternion_matrices(tum[keep, 4:])
    return (
        tum[keep, 0],
        np.unwrap(np.array(yaw))[at[keep]],
        np.unwrap(np.arctan2(truth[:, 1, 0], truth[:, 0, 0])),
    )


def yaw_error_deg(out, seconds: float) -> float:
    """The largest gap (degrees) between the integrated gyro's yaw and the trajectory's over
    the drive's first `seconds`."""
    from pathlib import Path

    times, gyro_yaw, tum_yaw = integrated_yaw(Path(out))
    first = times <= seconds
    return float(np.degrees(np.abs(gyro_yaw - tum_yaw))[first].max())
