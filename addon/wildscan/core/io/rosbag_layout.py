"""The drive's per-2D-scan ROS messages (tf, odometry, LaserScan) serialized many at once
with numpy: each has the same size every 2D scan (its frame names and beam count fixed), so
one structured dtype lays out all of its bytes, and a whole sweep's messages are one array.

The layouts follow the two wire formats rosbags writes (and tests compare byte for byte):
ROS 1 (little-endian, packed; a string is its uint32 length and its bytes; a Header starts
with the uint32 seq) and ROS 2's CDR (a 4-byte encapsulation header, 00 01 00 00 for
little-endian, then every primitive aligned to its own size counted from after it; a string
is its uint32 length with the terminating NUL, its bytes and the NUL).
http://wiki.ros.org/msg#Serialization, https://www.omg.org/spec/DDSI-RTPS/2.3 (10.2, CDR).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

CDR_LITTLE_ENDIAN = b"\x00\x01\x00\x00"


class Layout:
    """The byte layout of one fixed-size message, built field by field in wire order."""

    def __init__(self, cdr: bool):
        self.cdr = cdr
        self.size = len(CDR_LITTLE_ENDIAN) if cdr else 0
        self.fields: dict[str, tuple[int, np.dtype, tuple]] = {}
        self.constants: list[tuple[int, bytes]] = [(0, CDR_LITTLE_ENDIAN)] if cdr else []

    def _align(self, size: int) -> None:
        if self.cdr:  # padding bytes stay zero
            self.size += (-(self.size - len(CDR_LITTLE_ENDIAN))) % size

    def value(self, name: str, dtype: str, count: int = 0) -> None:
        """A primitive (count 0) or a fixed-length array of them."""
        dt = np.dtype(dtype)
        self._align(dt.itemsize)
        self.fields[name] = (self.size, dt, (count,) if count else ())
        self.size += dt.itemsize * max(count, 1)

    def sequence(self, name: str, dtype: str, count: int) -> None:
        """A variable-length array that holds `count` items in every message."""
        self.u32(count)
        self.value(name, dtype, count)

    def u32(self, number: int) -> None:
        self._align(4)
        self.constants.append((self.size, np.uint32(number).astype("<u4").tobytes()))
        self.size += 4

    def string(self, text: str) -> None:
        data = text.encode() + (b"\x00" if self.cdr else b"")
        self.u32(len(data))
        self.constants.append((self.size, data))
        self.size += len(data)

    def header(self, prefix: str, frame: str) -> None:
        """std_msgs/Header: ROS 1's seq, the stamp (sec, nanosec), the frame id."""
        if not self.cdr:
            self.value(f"{prefix}seq", "<u4")
        self.value(f"{prefix}sec", "<i4")
        self.value(f"{prefix}nanosec", "<u4")
        self.string(frame)

    def pack(self, count: int, **values) -> np.ndarray:
        """(count,) messages: uint8 rows of `size` bytes, the fields set from `values`."""
        dtype = np.dtype(
            {
                "names": list(self.fields),
                "formats": [(dt, shape) if shape else dt for _, dt, shape in self.fields.values()],
                "offsets": [offset for offset, _, _ in self.fields.values()],
                "itemsize": self.size,
            }
        )
        out = np.zeros(count, dtype=dtype)
        raw = out.view(np.uint8).reshape(count, self.size)
        for offset, data in self.constants:
            raw[:, offset : offset + len(data)] = np.frombuffer(data, dtype=np.uint8)
        for name, value in values.items():
            out[name] = value
        return raw


@lru_cache(maxsize=None)
def tf_layout(cdr: bool, frames: tuple[tuple[str, str], ...]) -> Layout:
    """tf2_msgs/TFMessage of len(frames) TransformStamped, (parent, child) each."""
    layout = Layout(cdr)
    layout.u32(len(frames))
    for i, (parent, child) in enumerate(frames):
        layout.header(f"{i}.", parent)
        layout.string(child)
        layout.value(f"{i}.translation", "<f8", 3)
        layout.value(f"{i}.rotation", "<f8", 4)
    return layout


@lru_cache(maxsize=None)
def odometry_layout(cdr: bool, frame: str, child: str) -> Layout:
    """nav_msgs/Odometry: pose (position, orientation, covariance), twist (linear, angular,
    covariance)."""
    layout = Layout(cdr)
    layout.header("", frame)
    layout.string(child)
    layout.value("position", "<f8", 3)
    layout.value("orientation", "<f8", 4)
    layout.value("pose_covariance", "<f8", 36)
    layout.value("linear", "<f8", 3)
    layout.value("angular", "<f8", 3)
    layout.value("twist_covariance", "<f8", 36)
    return layout


LASER_SCAN_FIELDS = (
    "angle_min",
    "angle_max",
    "angle_increment",
    "time_increment",
    "scan_time",
    "range_min",
    "range_max",
)


@lru_cache(maxsize=None)
def laser_scan_layout(cdr: bool, frame: str, beams: int) -> Layout:
    """sensor_msgs/LaserScan of `beams` ranges and intensities."""
    layout = Layout(cdr)
    layout.header("", frame)
    for name in LASER_SCAN_FIELDS:
        layout.value(name, "<f4")
    layout.sequence("ranges", "<f4", beams)
    layout.sequence("intensities", "<f4", beams)
    return layout


@lru_cache(maxsize=None)
def imu_layout(cdr: bool, frame: str) -> Layout:
    """sensor_msgs/Imu: orientation and its covariance, angular velocity and its covariance,
    linear acceleration and its covariance."""
    layout = Layout(cdr)
    layout.header("", frame)
    layout.value("orientation", "<f8", 4)
    layout.value("orientation_covariance", "<f8", 9)
    layout.value("angular_velocity", "<f8", 3)
    layout.value("angular_velocity_covariance", "<f8", 9)
    layout.value("linear_acceleration", "<f8", 3)
    layout.value("linear_acceleration_covariance", "<f8", 9)
    return layout
