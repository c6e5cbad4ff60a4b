"""The three output frames of a scan and moving points between them. Numpy only.

sensor   origin at the optical centre, tilted with the structure
leveled  same origin, Z vertical, X along the heading (paper Eq. 2; leveling.py)
world    Blender's world frame

A placement fixes all three: world = c + R·p_sensor = c + Rz(yaw)·p_leveled
(docs/architecture.md "Frames"). It is given either as a core.placement.Placement or as the
dict a scan stores in its metadata (`Placement.to_dict()`, angles in degrees).
"""

from __future__ import annotations

import numpy as np

from .. import detmath as dm
from ..checks import one_of
from .leveling import rot_z, sensor_to_world_matrix

FRAMES = ("leveled", "sensor", "world")


def check_frame(frame: str) -> str:
    return one_of(frame, "frame", FRAMES)


def _attitude(placement) -> tuple[np.ndarray, float, float, float]:
    """(optical centre, roll, pitch, yaw in radians) of a Placement or of its dict."""
    if isinstance(placement, dict):
        return (
            np.asarray(placement["optical_centre"], dtype=np.float64),
            dm.radians(placement["roll_deg"]),
            dm.radians(placement["pitch_deg"]),
            dm.radians(placement["pose"]["yaw_deg"]),
        )
    return placement.optical_centre, placement.roll_rad, placement.pitch_rad, placement.yaw_rad


def rotation_to_world(frame: str, roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """The rotation taking `frame` coordinates to world axes."""
    check_frame(frame)
    if frame == "leveled":
        return rot_z(yaw_rad)
    if frame == "sensor":
        return sensor_to_world_matrix(roll_rad, pitch_rad, yaw_rad)
    return np.eye(3)


def to_world(xyz: np.ndarray, frame: str, placement) -> np.ndarray:
    """(N,3) points of `frame` in world metres (float64)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if check_frame(frame) == "world":
        return xyz.copy()
    centre, roll, pitch, yaw = _attitude(placement)
    return centre + dm.apply(rotation_to_world(frame, roll, pitch, yaw), xyz)


def from_world(xyz: np.ndarray, frame: str, placement) -> np.ndarray:
    """(N,3) world points expressed in `frame` (float64)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if check_frame(frame) == "world":
        return xyz.copy()
    centre, roll, pitch, yaw = _attitude(placement)
    # R^T · (p - c), summed in a fixed order (dm.apply), not by BLAS
    return dm.apply(rotation_to_world(frame, roll, pitch, yaw).T, xyz - centre)


def convert(xyz: np.ndarray, source: str, target: str, placement) -> np.ndarray:
    """Points of frame `source` in frame `target` (a copy even when they are the same)."""
    if check_frame(source) == check_frame(target):
        return np.asarray(xyz, dtype=np.float64).reshape(-1, 3).copy()
    return from_world(to_world(xyz, source, placement), target, placement)
