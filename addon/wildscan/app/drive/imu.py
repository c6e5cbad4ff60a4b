"""A drive's IMU: its samples (core/motion/imu.py, exact; imu_models.py, with a datasheet's
errors), what the bags, imu.csv and calib.txt say of it (docs/motion.md#imu)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.io.imu_csv import imu_csv_text
from ...core.motion.imu import ImuMount, imu_truth, sample_stamps
from ...core.motion.imu_models import DEFAULT_MOUNT, MODELS, ImuModel, with_errors
from ...core.motion.placements import Motion
from ...core.placement import COLUMN_HEIGHT
from ...core.spatial.rotations import quaternions

IMU_CSV = "imu.csv"


@dataclass(frozen=True)
class DriveImu:
    model: ImuModel
    rate: int  # Hz
    noise: bool
    mount: ImuMount
    stamps: np.ndarray  # (n,) int64 ns
    orientation: np.ndarray  # (n, 4) the IMU frame in odom (x, y, z, w): the ground truth
    gyro: np.ndarray  # (n, 3) rad/s, as measured
    accel: np.ndarray  # (n, 3) m/s^2, as measured

    def covariances(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """sensor_msgs/Imu's three covariances: the orientation is the ground truth (0, as
        exact); the gyro's and accelerometer's diagonals are one sample's white-noise
        variance (0 with --imu-noise off)."""
        gyro, accel = self.model.white_sigmas(self.rate) if self.noise else (0.0, 0.0)
        return np.zeros(9), np.eye(3).ravel() * gyro**2, np.eye(3).ravel() * accel**2

    def window(self, start_ns: int, end_ns: int, last: bool):
        """The bags' `imu` argument for the samples in [start, end) (to the end when `last`)."""
        lo = int(np.searchsorted(self.stamps, start_ns, side="left"))
        hi = len(self.stamps) if last else int(np.searchsorted(self.stamps, end_ns, side="left"))
        part = slice(lo, hi)
        count = hi - lo
        covariances = tuple(np.broadcast_to(c, (count, 9)) for c in self.covariances())
        return (self.stamps[part], self.orientation[part], self.gyro[part], self.accel[part], covariances)

    def csv_text(self) -> str:
        return imu_csv_text(self.stamps, self.gyro, self.accel)

    def sensor_from_imu(self) -> np.ndarray:
        """(4, 4) IMU frame -> the lidar's `sensor` frame (0.723 m up base_link, same axes)."""
        out = self.mount.matrix.copy()
        out[2, 3] -= COLUMN_HEIGHT
        return out

    def static_transform(self) -> tuple:
        """tf_static's base_link -> imu."""
        q = quaternions(self.mount.rotation[None])[0]
        return tuple(float(v) for v in self.mount.translation), tuple(float(v) for v in q)

    def to_dict(self) -> dict:
        translation, rotation = self.static_transform()
        return {
            "model": self.model.to_dict(),
            "rate_hz": self.rate,
            "noise": self.noise,
            "samples": len(self.stamps),
            "mount": {
                "parent": "base_link",
                "translation": list(translation),
                "quaternion_xyzw": list(rotation),
            },
            "file": IMU_CSV,
        }


def drive_imu(
    motion: Motion, period_ns: int, scans_2d: int, model_name: str, rate: int, noise: bool, seed: int
) -> DriveImu | None:
    """The IMU samples of a drive of `scans_2d` 2D scans (None for `--imu none`)."""
    if model_name == "none":
        return None
    model = MODELS[model_name]
    stamps = sample_stamps(scans_2d * period_ns, rate)
    truth = imu_truth(motion, stamps, period_ns, DEFAULT_MOUNT)
    gyro, accel = truth.gyro, truth.accel
    if noise:
        gyro, accel = with_errors(gyro, accel, rate, model, seed)
    return DriveImu(model, rate, noise, DEFAULT_MOUNT, stamps, quaternions(truth.rotation), gyro, accel)
