"""Moving a scan's points between its output frames (numpy only, no bpy).

The viewport shows every cloud in the world frame, where it lies on the world
that was scanned; a file keeps the frame the user chose. Both are computed
from the placement a scan stores in its metadata (`Placement.to_dict()`):
world = c + R·p_sensor = c + Rz(yaw)·p_leveled (DESIGN.md "Frames").
"""

from __future__ import annotations

import math

import numpy as np

from ..core.leveling import rot_z, sensor_to_world_matrix
from ..core.scan import FRAMES


def _rotation_to_world(frame: str, placement: dict) -> np.ndarray:
    """The rotation taking `frame` coordinates to world axes."""
    yaw = math.radians(placement["pose"]["yaw_deg"])
    if frame == "leveled":
        return rot_z(yaw)
    if frame == "sensor":
        return sensor_to_world_matrix(
            math.radians(placement["roll_deg"]), math.radians(placement["pitch_deg"]), yaw
        )
    if frame == "world":
        return np.eye(3)
    raise ValueError(f"unknown frame {frame!r}; one of {', '.join(FRAMES)}")


def to_world(xyz: np.ndarray, frame: str, placement: dict) -> np.ndarray:
    """(N,3) points of `frame` in world metres (float64)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if frame == "world":
        return xyz.copy()
    centre = np.asarray(placement["optical_centre"], dtype=np.float64)
    return centre + xyz @ _rotation_to_world(frame, placement).T


def from_world(xyz: np.ndarray, frame: str, placement: dict) -> np.ndarray:
    """(N,3) world points expressed in `frame` (float64)."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if frame == "world":
        return xyz.copy()
    centre = np.asarray(placement["optical_centre"], dtype=np.float64)
    # Row vectors: (R^T · (p - c))^T = (p - c) · R
    return (xyz - centre) @ _rotation_to_world(frame, placement)


def convert(xyz: np.ndarray, source: str, target: str, placement: dict) -> np.ndarray:
    """Points of frame `source` in frame `target` (a copy even when they are the same)."""
    if source == target:
        return np.asarray(xyz, dtype=np.float64).reshape(-1, 3).copy()
    return from_world(to_world(xyz, source, placement), target, placement)
