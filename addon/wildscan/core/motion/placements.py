"""The robot standing on the ground at every 2D scan (column) of a drive (numpy only).

Each instant is placed exactly as `core.placement.place` places one pose (the probe from
above, the four downward lasers, the same checks and the same arithmetic, so a drive
standing still is placed as a static scan is), but the rays of many instants go to the
ray caster in a few large batches: one per probe layer, one for all the lasers, a chunk of
PLACE_CHUNK instants at a time. What is kept of every instant is a few arrays (the pose's
centre, ground point and attitude: part of trajectory.BYTES_PER_COLUMN);
a whole `Placement` (its pose, lasers and checks, for a scan's metadata) only at the
instants asked for, the 3D scans' starts.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from .. import detmath as dm
from ..backend import RayBackend
from ..errors import PoseRejected
from ..placement import (
    ARM_X,
    ARM_Y,
    COLUMN_HEIGHT,
    LASER_CLEARANCE,
    LASERS,
    MAX_TILT_DEG,
    MAX_UNEVENNESS,
    NO_GROUND,
    STANDING_IDS,
    Placement,
    Pose,
    cast_lasers_many,
    describe_pose,
    lasers_of,
    probe_ground_z_many,
    stand,
)
from ..spatial.leveling import roll_pitch_from_slopes
from ..spatial.rotations import log_map

# Instants placed per batch of casts: bounds the transient arrays of the probe and the lasers
# (about 2 KB an instant while placed: 32 MB) whatever the drive's length.
PLACE_CHUNK = 16_384


@dataclass
class Motion:
    """The robot's pose at the start of every 2D scan of a drive and at its very end."""

    times: np.ndarray  # (K + 1,) seconds from the drive's start
    distance: np.ndarray  # (K + 1,) metres driven along the path
    centre: np.ndarray  # (K + 1, 3) optical centre, world metres
    ground: np.ndarray  # (K + 1, 3) where the column meets the ground (base_link)
    rotation: np.ndarray  # (K + 1, 3, 3) sensor frame -> world frame
    step: np.ndarray  # (K, 3) rotation vector from the attitude at k to that at k + 1 (frame at k)
    kept: dict[int, Placement] = field(default_factory=dict)  # the whole placements asked for

    def placement(self, k: int) -> Placement:
        """The whole placement at the start of 2D scan `k` (one place_all was asked to keep)."""
        return self.kept[k]

    @property
    def still(self) -> np.ndarray:
        """(K,) whether the pose at k + 1 is exactly the pose at k (standing still)."""
        same_c = np.all(self.centre[1:] == self.centre[:-1], axis=1)
        same_r = np.all(self.rotation[1:] == self.rotation[:-1], axis=(1, 2))
        return same_c & same_r


def place_all(
    backend: RayBackend,
    times: np.ndarray,
    xy: np.ndarray,
    yaw_deg: np.ndarray,
    distance: np.ndarray,
    z_start: float | None = None,
    keep: Iterable[int] = (0,),
) -> Motion:
    """Stand the robot at every instant; PoseRejected naming where and when it cannot.
    `z_start`: the lasers start at this height at every instant, as `place` does for one
    pose (a drive under a roof: the probe from above would stand it on the roof). `keep`:
    the instants whose whole Placement the caller needs (Motion.placement; the first's by
    default)."""
    count, keep = len(times), set(keep)
    centre, ground, rotation = np.empty((count, 3)), np.empty((count, 3)), np.empty((count, 3, 3))
    kept: dict[int, Placement] = {}
    for a in range(0, count, PLACE_CHUNK):
        b = min(count, a + PLACE_CHUNK)
        poses = [
            Pose(float(x), float(y), float(yaw)).validate() for (x, y), yaw in zip(xy[a:b], yaw_deg[a:b])
        ]
        if z_start is not None:
            starts = np.full(len(poses), float(z_start))
        else:
            found = probe_ground_z_many(backend, xy[a:b])
            off = np.flatnonzero(~np.isfinite(found))
            if len(off):
                i = int(off[0])
                _reject(a + i, times, distance, f"{describe_pose(poses[i])} {NO_GROUND}")
            starts = found + LASER_CLEARANCE
        placed = _place_from(backend, poses, starts, times, distance, a, {k - a for k in keep if a <= k < b})
        centre[a:b], ground[a:b], rotation[a:b] = placed[:3]
        kept.update({a + i: p for i, p in placed[3].items()})
    return motion_of(times, distance, centre, ground, rotation, kept)


def _place_from(backend, poses: list[Pose], z_start: np.ndarray, times, distance, first: int, keep: set[int]):
    """(centre, ground, rotation, {i: Placement kept}) of the poses (instants first, first + 1,
    ...) with each pose's four lasers cast down from its `z_start`."""
    rows = cast_lasers_many(backend, poses, z_start)
    stood = stand_all(poses, rows)
    centre, ground, rotation = stood.optical.copy(), stood.ground.copy(), stood.rotation.copy()
    kept = {}
    for i in np.flatnonzero(~stood.fits):
        try:  # `stand` says why, in the words a static scan's placement uses
            p = stand(poses[i], float(z_start[i]), lasers_of(poses[i], rows[i]))
        except PoseRejected as e:
            _reject(first + int(i), times, distance, e.message)
        centre[i], ground[i], rotation[i] = p.optical_centre, p.ground_centre, p.rotation
        if i in keep:
            kept[int(i)] = p
    for i in keep:
        if stood.fits[i]:
            kept[i] = stood.placement(i, poses[i], lasers_of(poses[i], rows[i]))
    return centre, ground, rotation, kept


@dataclass
class Stood:
    """`stand`'s arithmetic for many poses at once (detmath's scalar and array functions give
    the same bits): where each pose's placement fits, its values."""

    fits: np.ndarray  # (K,) all four lasers on terrain, even and flat enough
    roll: np.ndarray  # (K,) rad
    pitch: np.ndarray
    ground: np.ndarray  # (K, 3) where the column meets the ground
    optical: np.ndarray  # (K, 3) the optical centre
    rotation: np.ndarray  # (K, 3, 3) sensor -> world

    def placement(self, i: int, pose: Pose, lasers) -> Placement:
        return Placement(
            pose=pose,
            optical_centre=self.optical[i],
            ground_centre=self.ground[i],
            roll_rad=float(self.roll[i]),
            pitch_rad=float(self.pitch[i]),
            lasers=lasers,
        )


def stand_all(poses: list[Pose], rows) -> Stood:
    """`stand` for every pose (rows of `cast_lasers_many`), as arrays; a pose that does not
    fit is left to `stand` to reject."""
    origins = np.stack([row[0] for row in rows]) if rows else np.zeros((0, len(LASERS), 3))
    distance = np.stack([row[1] for row in rows]) if rows else np.zeros((0, len(LASERS)))
    class_id = np.stack([row[2] for row in rows]) if rows else np.zeros((0, len(LASERS)), dtype=int)
    z = origins[:, :, 2] - distance  # LaserHit.hit_z
    z_front, z_rear, z_left, z_right = z.T
    with np.errstate(invalid="ignore"):
        unevenness = abs((z_front + z_rear) - (z_left + z_right)) / 2
        roll, pitch = roll_pitch_from_slopes(
            (z_front - z_rear) / (2 * ARM_X), (z_left - z_right) / (2 * ARM_Y)
        )
        tilt = dm.degrees(dm.arccos(np.maximum(-1.0, np.minimum(1.0, dm.cos(roll) * dm.cos(pitch)))))
        fits = (
            np.all(np.isin(class_id, STANDING_IDS), axis=1)
            & (unevenness <= MAX_UNEVENNESS)
            & (tilt <= MAX_TILT_DEG)
        )
    xy = np.array([[pose.x, pose.y] for pose in poses]).reshape(-1, 2)
    yaw = dm.radians(np.array([pose.yaw_deg for pose in poses], dtype=np.float64))
    rotation = sensor_to_world_matrices(roll, pitch, yaw)
    ground = np.column_stack([xy, (z_front + z_rear + z_left + z_right) / 4])
    optical = ground + dm.apply(rotation, [0.0, 0.0, COLUMN_HEIGHT])
    return Stood(fits, roll, pitch, ground, optical, rotation)


def sensor_to_world_matrices(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(K, 3, 3) `leveling.sensor_to_world_matrix` of each (roll, pitch, yaw): the same
    entries (rot_z, the paper's pitch matrix, rot_x) and the same products, batched."""
    count = len(roll)
    zero, one = np.zeros(count), np.ones(count)
    s, c = dm.sincos(-roll)
    turn_x = np.stack([one, zero, zero, zero, c, -s, zero, s, c], axis=1).reshape(-1, 3, 3)
    s, c = dm.sincos(-pitch)
    tilt = np.stack([c, zero, -s, zero, one, zero, s, zero, c], axis=1).reshape(-1, 3, 3)
    s, c = dm.sincos(yaw)
    heading = np.stack([c, -s, zero, s, c, zero, zero, zero, one], axis=1).reshape(-1, 3, 3)
    return dm.matmul(heading, dm.matmul(tilt, turn_x))


def motion_of(
    times: np.ndarray,
    distance: np.ndarray,
    centre: np.ndarray,
    ground: np.ndarray,
    rotation: np.ndarray,
    kept: dict[int, Placement] | None = None,
) -> Motion:
    """The motion of a drive from its poses' arrays (K + 1 each)."""
    relative = dm.matmul(np.swapaxes(rotation[:-1], 1, 2), rotation[1:])  # R_k^T R_{k+1}
    step = log_map(relative)
    same = np.all(rotation[1:] == rotation[:-1], axis=(1, 2))
    step[same] = 0.0  # exactly: a robot standing still does not turn by rounding
    return Motion(
        times=np.asarray(times, dtype=np.float64),
        distance=np.asarray(distance, dtype=np.float64),
        centre=centre,
        ground=ground,
        rotation=rotation,
        step=step,
        kept=dict(kept or {}),
    )


def _reject(i: int, times: np.ndarray, distance: np.ndarray, why: str) -> None:
    raise PoseRejected(
        f"the drive stops at t = {times[i]:.3f} s (2D scan {i}, {distance[i]:.2f} m along the path): {why}"
    )
