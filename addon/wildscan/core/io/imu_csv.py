"""IMU samples as CSV in the EuRoC MAV dataset's `imu0/data.csv` layout (numpy only), which
VINS-Mono, OpenVINS, ORB-SLAM3 and Kalibr's bag tools read as it is:

    #timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],
    a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]          (one line: HEADER)

one sample a line: its time in whole nanoseconds (from the drive's start), the angular
velocity and the specific force (acceleration minus gravity: +9.81 up at rest), both in the
IMU's own frame (M. Burri et al., "The EuRoC micro aerial vehicle datasets", IJRR 2016).
Exactly seven columns: loaders index them by position.
"""

from __future__ import annotations

import numpy as np

HEADER = (
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"
)
_ROW = "%d,%.12f,%.12f,%.12f,%.9f,%.9f,%.9f"


def imu_csv_text(stamps_ns: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> str:
    """The samples as EuRoC CSV text; values to 1e-12 (rad/s) and 1e-9 (m/s^2)."""
    columns = (np.asarray(stamps_ns, dtype=np.int64).tolist(), *np.asarray(gyro).T.tolist())
    columns += tuple(np.asarray(accel).T.tolist())
    return "\n".join([HEADER] + [_ROW % row for row in zip(*columns)]) + "\n"


def read_imu_csv(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stamps_ns (n,) int64, gyro (n, 3), accel (n, 3)) of EuRoC IMU CSV text."""
    rows = [line.split(",") for line in text.splitlines() if line.strip() and not line.startswith("#")]
    stamps = np.array([int(r[0]) for r in rows], dtype=np.int64)
    values = np.array([r[1:7] for r in rows], dtype=np.float64).reshape(-1, 6)
    return stamps, values[:, :3], values[:, 3:]
