"""What an IMU on the robot measures during a drive, exactly (numpy only): angular velocity
and specific force in the IMU's own frame, from the derivatives of a smooth trajectory
through the poses the scans use.

The drive places the robot at the start of every 2D scan (placements.py: K + 1 knots,
`period` apart): where its column meets the ground (base_link) and its yaw, pitch, roll
(the attitude is `sensor_to_world_matrices(roll, pitch, yaw)` = Rz(yaw) Ry(pitch) Rx(-roll)).
Between knots the sweep moves the sensor on a straight line, which has no second
derivative worth measuring (its acceleration is a train of impulses at the knots), so the
IMU sees the C2 curve through the very same knots: each of x, y, z, yaw, pitch, roll is a
quintic Hermite polynomial on every interval, matching at both knots the value, the first
derivative (central difference of the knots) and the second derivative (second central
difference), so position, velocity and acceleration, attitude, angular velocity and angular
acceleration are continuous. The robot starts and stops as the drive does (at its speed, no
ramp): at the ends the first derivative is the one-sided difference and the second 0.
At a knot the curve is the knot's pose exactly; between knots it departs from the sweep's
straight line by under 0.5 mm on smooth ground, up to about a centimetre next to a jump of
the placement (tests/test_imu.py, tests/test_drive_imu.py measure it).

From that curve, with the attitude R(t) of base_link and the IMU's mount (translation m in
base_link, rotation M: IMU axes -> base_link axes), exactly (no finite differences):

    body rate       w  = yaw' (BC)^T e_z + pitch' C^T e_y - roll' e_x      (B = Ry(pitch), C = Rx(-roll))
    its derivative  w' = yaw'' u + yaw' u' + pitch'' v + pitch' v' - roll'' e_x
                          (u = (BC)^T e_z, u' = roll' e_x x u - pitch' C^T (e_y x B^T e_z);
                           v = C^T e_y,    v' = roll' e_x x v)
    gyro            M^T w
    accelerometer   M^T (R^T p'' + w' x m + w x (w x m) + R^T (0, 0, g))

i.e. the specific force: acceleration minus gravity, so an IMU at rest reads +g up (as a
datasheet's axis table says: Bosch BMI088 DS001 section 8.2, +1 g on Z lying flat). The
arithmetic is detmath's and plain products and sums: the same bits on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from .placements import Motion, sensor_to_world_matrices
from .trajectory import unwrap

# Standard gravity, m/s^2: the 3rd CGPM (1901), the value ISO 80000-3 keeps. The drive's
# world has no geoid: gravity is this, straight down -Z, everywhere.
GRAVITY = 9.80665
E_X, E_Y, E_Z = np.eye(3)
CHUNK = 1 << 16  # samples evaluated at once: bounds the memory of a drive of kilometres


@dataclass(frozen=True)
class ImuMount:
    """Where the IMU sits on the robot: its origin in base_link (metres) and the rotation
    taking IMU axes to base_link axes."""

    translation: tuple[float, float, float]
    rotation: np.ndarray  # (3, 3)

    @property
    def matrix(self) -> np.ndarray:
        """(4, 4) IMU frame -> base_link."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.translation
        return out


@dataclass(frozen=True)
class ImuTruth:
    """The exact readings at each sample: time, the IMU's pose in the world, its gyro and
    accelerometer (IMU frame)."""

    stamps_ns: np.ndarray  # (n,) int64, ns from the drive's start
    position: np.ndarray  # (n, 3) the IMU's origin, world metres
    rotation: np.ndarray  # (n, 3, 3) IMU frame -> world
    gyro: np.ndarray  # (n, 3) rad/s
    accel: np.ndarray  # (n, 3) m/s^2, specific force

    @property
    def times(self) -> np.ndarray:
        return self.stamps_ns / 1e9


def sample_stamps(duration_ns: int, rate_hz: int) -> np.ndarray:
    """(n,) int64 stamps i * 1e9 // rate of the samples in [0, duration): whole nanoseconds,
    so a sample's time is its bag stamp exactly."""
    count = -(-int(duration_ns) * int(rate_hz) // 10**9)  # ceil(duration * rate)
    return np.arange(count, dtype=np.int64) * 10**9 // int(rate_hz)


def knot_values(motion: Motion) -> np.ndarray:
    """(K + 1, 6): base_link's x, y, z and the attitude's yaw (unwrapped), pitch, roll (rad)
    at every knot of the drive."""
    yaw = unwrap(dm.radians(np.array([p.pose.yaw_deg for p in motion.placements], dtype=np.float64)))
    pitch = np.array([p.pitch_rad for p in motion.placements], dtype=np.float64)
    roll = np.array([p.roll_rad for p in motion.placements], dtype=np.float64)
    return np.column_stack([motion.ground, yaw, pitch, roll])


def knot_derivatives(values: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second derivatives at evenly spaced knots (h apart): central differences
    inside; at the ends the one-sided difference and 0 (the drive starts and stops at speed)."""
    first = np.empty_like(values)
    second = np.zeros_like(values)
    if len(values) < 2:
        first[:] = 0.0
        return first, second
    first[0] = (values[1] - values[0]) / h
    first[-1] = (values[-1] - values[-2]) / h
    first[1:-1] = (values[2:] - values[:-2]) / (2 * h)
    second[1:-1] = ((values[2:] - values[1:-1]) - (values[1:-1] - values[:-2])) / (h * h)
    return first, second


def quintic_coefficients(values: np.ndarray, h: float) -> np.ndarray:
    """(6, K, channels) coefficients c0..c5 of each interval's polynomial in s = (t - t_k) / h
    with value, slope and curvature of both knots (quintic Hermite)."""
    first, second = knot_derivatives(values, h)
    p0, p1 = values[:-1], values[1:]
    v0, v1 = first[:-1] * h, first[1:] * h
    a0, a1 = second[:-1] * (h * h), second[1:] * (h * h)
    d = p1 - p0
    c3 = 10 * d - 6 * v0 - 4 * v1 - (3 * a0 - a1) / 2
    c4 = -15 * d + 8 * v0 + 7 * v1 + (3 * a0 - 2 * a1) / 2
    c5 = 6 * d - 3 * v0 - 3 * v1 - (a0 - a1) / 2
    return np.stack([p0, v0, a0 / 2, c3, c4, c5])


def evaluate(coefficients: np.ndarray, stamps_ns: np.ndarray, period_ns: int):
    """(value, first, second derivative w.r.t. time), (n, channels) each, at the stamps."""
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    k = np.minimum(stamps // period_ns, coefficients.shape[1] - 1)
    s = ((stamps - k * period_ns) / period_ns)[:, None]
    h = period_ns / 1e9
    c0, c1, c2, c3, c4, c5 = (c[k] for c in coefficients)
    value = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
    first = (c1 + s * (2 * c2 + s * (3 * c3 + s * (4 * c4 + s * (5 * c5))))) / h
    second = (2 * c2 + s * (6 * c3 + s * (12 * c4 + s * (20 * c5)))) / (h * h)
    return value, first, second


def _rot_x(a: np.ndarray) -> np.ndarray:
    s, c = dm.sincos(a)
    zero, one = np.zeros_like(a), np.ones_like(a)
    return np.stack([one, zero, zero, zero, c, -s, zero, s, c], axis=1).reshape(-1, 3, 3)


def _rot_y(a: np.ndarray) -> np.ndarray:
    s, c = dm.sincos(a)
    zero, one = np.zeros_like(a), np.ones_like(a)
    return np.stack([c, zero, s, zero, one, zero, -s, zero, c], axis=1).reshape(-1, 3, 3)


def body_rates(angles, rates, accelerations) -> tuple[np.ndarray, np.ndarray]:
    """(w, w') in base_link, (n, 3) each, of the attitude Rz(yaw) Ry(pitch) Rx(-roll) from
    the angles (yaw, pitch, roll), their rates and their second derivatives, (n, 3) each."""
    _, pitch, roll = angles.T
    dy, dp, dr = rates.T
    ddy, ddp, ddr = accelerations.T
    c_t = _rot_x(roll)  # C^T = Rx(roll)
    b_t_ez = dm.apply(_rot_y(-pitch), E_Z)  # B^T e_z
    u = dm.apply(c_t, b_t_ez)  # (BC)^T e_z
    v = dm.apply(c_t, np.broadcast_to(E_Y, u.shape))  # C^T e_y
    ex = np.broadcast_to(E_X, u.shape)
    w = dy[:, None] * u + dp[:, None] * v - dr[:, None] * ex
    du = dr[:, None] * dm.cross(ex, u) - dp[:, None] * dm.apply(
        c_t, dm.cross(np.broadcast_to(E_Y, u.shape), b_t_ez)
    )
    dv = dr[:, None] * dm.cross(ex, v)
    dw = ddy[:, None] * u + dy[:, None] * du + ddp[:, None] * v + dp[:, None] * dv - ddr[:, None] * ex
    return w, dw


def imu_truth(motion: Motion, stamps_ns: np.ndarray, period_ns: int, mount: ImuMount) -> ImuTruth:
    """The exact IMU readings of a drive at `stamps_ns` (in [0, K * period)), CHUNK samples at
    a time (each sample's numbers are its own: the same bits whatever the chunks)."""
    coefficients = quintic_coefficients(knot_values(motion), period_ns / 1e9)
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    parts = [
        _readings(coefficients, stamps[i : i + CHUNK], period_ns, mount) for i in range(0, len(stamps), CHUNK)
    ]
    if not parts:
        parts = [_readings(coefficients, stamps, period_ns, mount)]
    return ImuTruth(stamps, *(np.concatenate(field) for field in zip(*parts)))


def _readings(coefficients: np.ndarray, stamps: np.ndarray, period_ns: int, mount: ImuMount):
    """(position, rotation, gyro, accel) of ImuTruth at `stamps`."""
    value, first, second = evaluate(coefficients, stamps, period_ns)
    angles = value[:, 3:]
    rotation = sensor_to_world_matrices(angles[:, 2], angles[:, 1], angles[:, 0])  # base_link -> world
    to_base = np.swapaxes(rotation, 1, 2)
    w, dw = body_rates(angles, first[:, 3:], second[:, 3:])
    m = np.broadcast_to(np.asarray(mount.translation, dtype=np.float64), w.shape)
    lever = dm.cross(dw, m) + dm.cross(w, dm.cross(w, m))
    force = dm.apply(to_base, second[:, :3]) + lever + dm.apply(to_base, np.array([0.0, 0.0, GRAVITY]))
    mount_t = np.asarray(mount.rotation, dtype=np.float64).T  # base_link -> IMU
    return (
        value[:, :3] + dm.apply(rotation, m),
        dm.matmul(rotation, np.broadcast_to(mount.rotation, rotation.shape)),
        dm.apply(mount_t, w),
        dm.apply(mount_t, force),
    )
