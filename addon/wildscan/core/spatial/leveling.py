"""Rotations between the sensor, leveled and world frames (paper Eq. 2). Numpy only.

Eq. (2) as printed has a typo: the top-right entry of its pitch matrix reads
−cos(−β) where −sin(−β) belongs (as printed the matrix is not a rotation).
With the fix, Eq. (2) maps sensor coordinates to leveled ones:

    leveled = Ry'(−β) · Rx(−α) · sensor,   Ry'(t) = [[cos t, 0, −sin t], [0, 1, 0], [sin t, 0, cos t]]

(Ry'(t) is the standard Ry(−t)). The angles are therefore defined by the
structure's attitude in its heading frame: pitch β > 0 when the front (+X) arm
tip is lower than the rear one (nose down), roll α > 0 when the left (+Y) arm
tip is lower than the right one. The property that decides it (docs/architecture.md "Frames"):
without noise, every leveled point equals Rz(−yaw) · (p_world − optical_centre).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import detmath as dm

# All angles go through detmath (not `math`, whose glibc code differs by CPU) and the
# products through dm.matmul/dm.apply (not @, whose BLAS kernel differs by CPU).


def rot_x(t: float) -> np.ndarray:
    s, c = dm.sincos(t)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(t: float) -> np.ndarray:
    s, c = dm.sincos(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def paper_pitch_matrix(t: float) -> np.ndarray:
    """The pitch factor of Eq. (2) with its typo fixed (−sin in the top-right entry)."""
    s, c = dm.sincos(t)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def leveling_matrix(roll_rad: float, pitch_rad: float) -> np.ndarray:
    """Eq. (2): sensor-frame coordinates -> leveled-frame coordinates."""
    if np.ndim(roll_rad) or np.ndim(pitch_rad):
        return _leveling(roll_rad, pitch_rad)
    return _kept_leveling(float(roll_rad).hex(), float(pitch_rad).hex()).copy()


def sensor_to_world_matrix(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """The sensor's axes in the world frame: heading rotation after leveling."""
    return dm.matmul(rot_z(yaw_rad), leveling_matrix(roll_rad, pitch_rad))


def _leveling(roll_rad, pitch_rad) -> np.ndarray:
    return dm.matmul(paper_pitch_matrix(-pitch_rad), rot_x(-roll_rad))


@functools.lru_cache(maxsize=16)
def _kept_leveling(roll_hex: str, pitch_hex: str) -> np.ndarray:
    """Eq. (2) of the last few (roll, pitch), by their bits (0.0 and -0.0 apart): a scan asks
    for its pose's several times (standing it, its rays, its points), each from detmath's
    scalar sines and cosines. Callers get a copy: none can change the one kept."""
    return _leveling(float.fromhex(roll_hex), float.fromhex(pitch_hex))


def roll_pitch_from_slopes(slope_x: float, slope_y: float) -> tuple[float, float]:
    """Roll and pitch (radians) of a structure resting on the plane z = slope_x·u + slope_y·v,
    with u along the heading and v to its left.

    The structure's Z axis must be the plane normal (−slope_x, −slope_y, 1)/‖·‖.
    """
    pitch = -dm.arctan(slope_x)
    roll = dm.arctan(-slope_y * dm.cos(pitch))
    return roll, pitch


def tilt_deg(roll_rad: float, pitch_rad: float) -> float:
    """Angle between the column and the vertical."""
    return dm.degrees(dm.arccos(max(-1.0, min(1.0, dm.cos(roll_rad) * dm.cos(pitch_rad)))))


def level_points(points_sensor: np.ndarray, roll_rad: float, pitch_rad: float) -> np.ndarray:
    return dm.apply(leveling_matrix(roll_rad, pitch_rad), points_sensor)
