"""The path the robot drives and where it is along it at each instant (numpy only).

A path is a polyline in the world's xy plane (metres), driven from its first point at
constant speed, heading along it: along each segment in its direction, turning linearly
with distance from one segment's direction to the next within TURN (0.5 m) of the vertex
between them (within half a segment where segments are shorter, as on the trail, sampled
every 0.5 m: there the heading turns smoothly all along). A straight path keeps the yaw
it was given. Lengths, headings and interpolation are detmath's (the poses are outputs:
the same bits on every CPU).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..errors import UserError
from .timing import SCAN_PERIOD

MAX_SPEED = 10.0  # m/s; a skid-steer robot like Andabata drives about 1 m/s
DEFAULT_SPEED = 1.0  # m/s
# What a drive holds per column (a 2D scan of the UTM-30LX-EW, a firing cycle of a spinning
# lidar) at its peak, for its whole length: Motion's arrays (8 + 8 + 24 + 24 + 72 + 24 B) and
# their temporaries (the attitude steps' log map), the instants, the bags' attitudes and
# velocities and the TUM trajectory's text. Measured as the peak RSS's slope between drives of
# 100 and 400 VLP-16 revolutions (180,900 and 723,600 firing cycles, seed 1, low detail):
# 980 B (--bag none), 1,180 B (both bags). Every other array a drive makes is bounded: one 3D
# scan's beams at a time, placements in chunks (placements.PLACE_CHUNK).
BYTES_PER_COLUMN = 1_200
MAX_DRIVE_BYTES = 2 << 30  # the most those may take: 2 GiB, 1.79 M columns (99 s of a VLP-16)
MAX_COLUMNS = MAX_DRIVE_BYTES // BYTES_PER_COLUMN
_SAME_POINT = 1e-9  # m: consecutive waypoints closer than this are one
TURN = 0.5  # m: the heading turns from one segment's direction to the next within this of a vertex


@dataclass(frozen=True)
class Path:
    """A polyline driven from its first point; `yaw_deg` fixes the heading of a straight path."""

    points: np.ndarray  # (n, 2) world metres, consecutive points distinct (n >= 1)
    kind: str  # "trail", "waypoints" or "straight"
    yaw_deg: float | None = None  # a straight path's heading (degrees CCW from +X)

    @property
    def arc(self) -> np.ndarray:
        """(n,) distance along the path to each point."""
        return np.concatenate([[0.0], np.cumsum(step_lengths(self.points))])

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(xy (K, 2), yaw in degrees (K,)) at distances `s` along the path."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        if len(self.points) == 1:
            return np.repeat(self.points, len(s), axis=0), np.full(len(s), float(self.yaw_deg or 0.0))
        arc = self.arc
        xy = np.column_stack([dm.interp(s, arc, self.points[:, 0]), dm.interp(s, arc, self.points[:, 1])])
        if self.yaw_deg is not None:
            return xy, np.full(len(s), float(self.yaw_deg))
        knots, headings = heading_knots(self.points, arc)
        return xy, dm.degrees(dm.interp(s, knots, headings))


def step_lengths(points: np.ndarray) -> np.ndarray:
    """(n - 1,) the length of each step of a polyline (n, 2): sqrt(dx dx + dy dy), as
    np.linalg.norm gives it, but with no SIMD or BLAS kernel to choose the order."""
    d = np.diff(points, axis=0)
    return np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])


def unwrap(angles: np.ndarray) -> np.ndarray:
    """np.unwrap's meaning (each jump of more than pi made the one within pi), spelt out in
    operations IEEE rounds alike everywhere: rint and exact multiples of 2 pi."""
    jumps = np.diff(angles)
    turns = np.rint(jumps / (2 * math.pi))
    fixes = np.concatenate([[0.0], np.cumsum(-turns * (2 * math.pi))])
    return angles + fixes


def heading_knots(points: np.ndarray, arc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance, heading in radians, unwrapped) knots of the heading along a polyline: each
    segment's own direction along it, turning linearly from one to the next within TURN of
    each inner vertex (at most half of either segment beside it)."""
    d = np.diff(points, axis=0)
    segment = unwrap(dm.arctan2(d[:, 1], d[:, 0]))
    lengths = np.diff(arc)
    turn = np.minimum(TURN, np.minimum(lengths[:-1], lengths[1:]) / 2)  # one per inner vertex
    s = [[arc[0]]]
    h = [[segment[0]]]
    for i, r in enumerate(turn, start=1):
        s.append([arc[i] - r, arc[i] + r])
        h.append([segment[i - 1], segment[i]])
    s.append([arc[-1]])
    h.append([segment[-1]])
    return np.concatenate(s), np.concatenate(h)


def straight_path(x: float, y: float, yaw_deg: float, distance: float) -> Path:
    """From (x, y) straight ahead along `yaw_deg` for `distance` metres."""
    for name, value in (("x", x), ("y", y), ("yaw", yaw_deg)):
        if not math.isfinite(value):
            raise UserError(f"{name} must be a finite number, got {value}", setting="from")
    if not math.isfinite(distance) or distance < 0:
        raise UserError(f"must be a distance of 0 m or more, got {distance:g}", setting="distance")
    start = np.array([[x, y]], dtype=np.float64)
    if distance == 0:
        return Path(start, "straight", yaw_deg)
    yaw = dm.radians(yaw_deg)
    end = start + distance * np.array([[dm.cos(yaw), dm.sin(yaw)]])
    return Path(np.concatenate([start, end]), "straight", yaw_deg)


def polyline_path(points, kind: str, setting: str) -> Path:
    """A path through `points` (n, 2); consecutive repeats are dropped. It must have length."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts):
        pts = pts[np.concatenate([[True], step_lengths(pts) > _SAME_POINT])]
    if len(pts) < 2:
        raise UserError("needs at least two different points to drive along", setting=setting)
    return Path(pts, kind)


def check_speed(speed: float) -> float:
    if not isinstance(speed, (int, float)) or not math.isfinite(speed) or not 0 <= speed <= MAX_SPEED:
        raise UserError(
            f"must be from 0 (standing still) to {MAX_SPEED:g} m/s, got {speed:g}",
            setting="speed",
            allowed=(0, MAX_SPEED),
        )
    return float(speed)


@dataclass(frozen=True)
class Schedule:
    """How many 2D and 3D scans a drive takes."""

    scans_2d: int  # K: 2D scans, every one on /laser2D and in the trajectory
    scans_3d: int  # J: complete 3D scans (the first J * sweeps 2D scans)
    sweeps: int  # M: 2D scans in a 3D scan
    period: float = SCAN_PERIOD  # s a 2D scan: the device's column period

    @property
    def duration(self) -> float:
        return self.scans_2d * self.period


def schedule(
    path: Path,
    speed: float,
    sweeps: int,
    scans_3d: int | None = None,
    period: float = SCAN_PERIOD,
    columns: str = "2D scans of the UTM-30LX-EW",
) -> Schedule:
    """The 2D scans of a drive along `path` at `speed`: as many as fit until the robot reaches
    the path's end (all of them, then, whole 3D scans or not), or exactly `scans_3d` 3D scans.
    Standing still (speed 0) takes `scans_3d` (default 1) 3D scans. `period`: the device's
    time a 2D scan (sensors/device.py Timing.column_period_s); `columns`: what the device's
    columns are called, for the message when the drive would be too long
    (Device.columns_named)."""
    speed = check_speed(speed)
    if scans_3d is not None:
        scans_2d = scans_3d * sweeps
        need = speed * scans_2d * period
        if need > path.length * (1 + 1e-12) + 1e-9:
            raise UserError(
                f"{scans_3d} 3D scans at {speed:g} m/s need {need:.2f} m of path, and the path is "
                f"{path.length:.2f} m long",
                setting="scans",
            )
    elif speed == 0:
        scans_2d = sweeps
    else:
        # a whisker of slack so a path of exactly K periods' length gives K, not K - 1
        scans_2d = int(math.floor(path.length / (speed * period) * (1 + 1e-12) + 1e-9))
    if scans_2d > MAX_COLUMNS:
        raise UserError(
            f"the drive would take {scans_2d:,} {columns} ({scans_2d * period:,.0f} s); a drive keeps "
            f"{BYTES_PER_COLUMN:,} bytes of trajectory for each of them, at most "
            f"{MAX_DRIVE_BYTES >> 30} GiB: {MAX_COLUMNS:,} ({MAX_COLUMNS * period:,.0f} s of this device); "
            "drive a shorter path or faster",
            setting="speed",
        )
    if scans_2d < sweeps:
        raise UserError(
            f"the path ({path.length:.2f} m at {speed:g} m/s, {scans_2d * period:.2f} s) is shorter "
            f"than one 3D scan ({sweeps} 2D scans, {sweeps * period:g} s); drive farther or slower",
            setting="speed",
        )
    return Schedule(scans_2d, scans_2d // sweeps, sweeps, period)


def instants(
    path: Path, speed: float, count: int, period: float = SCAN_PERIOD
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the robot is at the start of 2D scans 0 ... count - 1 (`period` s apart): (time
    (count,), xy (count, 2), yaw in degrees (count,))."""
    t = np.arange(count, dtype=np.float64) * period
    xy, yaw = path.at(speed * t)
    return t, xy, yaw
