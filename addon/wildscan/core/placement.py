"""Standing the sensor structure on the ground the way Andabata would (paper IV-A). Numpy only.

The structure has two arms, along its local X (the heading) and Y, with a
downward 1D laser at each arm tip, and a column carrying the optical centre
0.723 m above the ground. The four laser distances give the ground's height,
roll and pitch; the four reflectivities check that all four lasers land on
terrain or flooring.

Arm half-lengths follow Andabata's footprint (about 0.67 m long and 0.54 m
wide), so every tip lies well inside the blind cone, whose radius on flat ground
equals the column height (0.723 m): the structure never shows up in a scan.

How the lasers find the ground: unless the user gives a start height
(z_start), a probe is cast straight down from high above the pose; it passes
through everything that is not terrain or water (tree crowns, wires, tables,
rocks — the robot may stand under them or be rejected by its lasers, not by the
probe) and stops at the first terrain or water surface. The four lasers then
start LASER_CLEARANCE above that surface, so an overhead crown is never
mistaken for the ground while a rock, bench or table under the footprint still
is. In the paper biome the first terrain surface from above a cave is its roof;
to stand inside the cave there, give a z_start under the roof. Where the biome
covers the ground the roof and the pit's walls are rock: the probe passes them
and a pose under the roof stands on the cave's floor (over a wall it finds
nothing under the rock face and is rejected).

The lasers cannot see a trunk standing between them (a pose right at a tree): then
the column would put the optical centre inside the trunk. So four horizontal rays leave
the optical centre along the arms; when all four meet the same element within
ENCLOSED_REACH, the sensor would be inside it and the pose is rejected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import detmath as dm
from .backend import RayBackend
from .classes import BY_ID, GROUND_CLASS_IDS, WATER_ID
from .errors import PoseRejected, UserError
from .spatial.leveling import roll_pitch_from_slopes, rot_z, sensor_to_world_matrix, tilt_deg

COLUMN_HEIGHT = 0.723  # m, optical centre above the ground (paper section II)
ARM_X = 0.335  # m, half-length of the X arm (half of Andabata's ~0.67 m length)
ARM_Y = 0.27  # m, half-length of the Y arm (half of Andabata's ~0.54 m width)
MAX_TILT_DEG = 25.0  # steeper than this, a skid-steer robot like Andabata slips or tips over
MAX_UNEVENNESS = 0.10  # m, the two arms' mid-heights may differ this much before the robot would rock
LASER_CLEARANCE = 1.0  # m, lasers start this far above the ground the probe found
PROBE_TOP_Z = 10_000.0  # m, the probe starts here (worlds are far lower)
PROBE_MAX_LAYERS = 64  # surfaces the probe may pass through before giving up
PROBE_STEP = 1e-4  # m, how far past a surface the probe restarts
ENCLOSED_REACH = 1.0  # m: an element met this close in all four arm directions encloses the sensor
MAX_COORDINATE = 1e6  # m; float64 keeps 0.1 um steps out there, and no world is bigger

TERRAIN_ID = 1
# what the robot stands on: the terrain, or on the endless landscape its ground's materials
STANDING_IDS = GROUND_CLASS_IDS
# why a pose whose probe finds no terrain or water below it is rejected
NO_GROUND = "is off the world: there is no terrain below it (nor under any rock face it passes)"

# (name, offset along heading, offset to the left)
LASERS: tuple[tuple[str, float, float], ...] = (
    ("front (+X)", ARM_X, 0.0),
    ("rear (-X)", -ARM_X, 0.0),
    ("left (+Y)", 0.0, ARM_Y),
    ("right (-Y)", 0.0, -ARM_Y),
)


@dataclass(frozen=True)
class Pose:
    """Where the user wants the scan: x, y (world metres), yaw (degrees CCW from +X)."""

    x: float
    y: float
    yaw_deg: float

    def validate(self) -> "Pose":
        for name, v in (("x", self.x), ("y", self.y), ("yaw", self.yaw_deg)):
            if not math.isfinite(v):
                raise UserError(f"{name} must be a finite number, got {v}", setting="pose")
        for name, v in (("x", self.x), ("y", self.y)):
            if abs(v) > MAX_COORDINATE:
                raise UserError(f"{name} must be within +-{MAX_COORDINATE:g} m, got {v:g}", setting="pose")
        return self

    def to_dict(self) -> dict:
        return {"x": self.x, "y": self.y, "yaw_deg": self.yaw_deg}


@dataclass(frozen=True)
class LaserHit:
    name: str
    origin: tuple[float, float, float]
    distance: float  # inf when the laser saw nothing
    class_id: int  # -1 for a miss
    instance: int

    @property
    def hit_z(self) -> float:
        return self.origin[2] - self.distance

    @property
    def class_name(self) -> str:
        return BY_ID[self.class_id].name if self.class_id >= 0 else "nothing"

    def describe(self) -> str:
        if self.class_id < 0:
            return f"laser {self.name} hit nothing"
        what = self.class_name if self.class_id else "an untagged object"
        return f"laser {self.name} hit {what} at z={self.hit_z:.3f}"

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "origin": list(self.origin),
            "distance": self.distance if math.isfinite(self.distance) else None,
            "hit_z": self.hit_z if math.isfinite(self.distance) else None,
            "class": self.class_name,
            "reflectivity": BY_ID[self.class_id].reflectivity if self.class_id >= 0 else None,
            "instance": self.instance,
        }


@dataclass(frozen=True)
class Placement:
    pose: Pose
    optical_centre: np.ndarray  # (3,) world metres
    ground_centre: np.ndarray  # (3,) where the column meets the fitted ground plane
    roll_rad: float
    pitch_rad: float
    lasers: tuple[LaserHit, ...] = field(default=())

    @property
    def yaw_rad(self) -> float:
        return dm.radians(self.pose.yaw_deg)

    @property
    def roll_deg(self) -> float:
        return dm.degrees(self.roll_rad)

    @property
    def pitch_deg(self) -> float:
        return dm.degrees(self.pitch_rad)

    @property
    def tilt_deg(self) -> float:
        """Angle between the column and the vertical."""
        return tilt_deg(self.roll_rad, self.pitch_rad)

    @property
    def rotation(self) -> np.ndarray:
        """Sensor frame -> world frame."""
        return sensor_to_world_matrix(self.roll_rad, self.pitch_rad, self.yaw_rad)

    def to_dict(self) -> dict:
        return {
            "pose": self.pose.to_dict(),
            "optical_centre": [float(v) for v in self.optical_centre],
            "ground_centre": [float(v) for v in self.ground_centre],
            "roll_deg": self.roll_deg,
            "pitch_deg": self.pitch_deg,
            "tilt_deg": self.tilt_deg,
            "column_height": COLUMN_HEIGHT,
            "arm_half_lengths": [ARM_X, ARM_Y],
            "lasers": [laser.to_dict() for laser in self.lasers],
        }


def check_z_start(z_start: float | None) -> float | None:
    if z_start is not None and (not math.isfinite(z_start) or abs(z_start) > MAX_COORDINATE):
        raise UserError(
            f"must be a height within +-{MAX_COORDINATE:g} m, got {z_start:g}",
            setting="z_start",
            allowed=(-MAX_COORDINATE, MAX_COORDINATE),
        )
    return z_start


def laser_xy(pose: Pose) -> np.ndarray:
    """(4,2) horizontal positions of the arm tips."""
    s, c = dm.sincos(dm.radians(pose.yaw_deg))
    dx, dy = np.array([[dx, dy] for _, dx, dy in LASERS]).T
    return np.column_stack([pose.x + (c * dx - s * dy), pose.y + (s * dx + c * dy)])


def probe_ground_z(backend: RayBackend, x: float, y: float) -> float | None:
    """Height of the first terrain or water surface straight below (x, y), seen from above."""
    z = probe_ground_z_many(backend, np.array([[x, y]]))[0]
    return float(z) if np.isfinite(z) else None


def probe_ground_z_many(backend: RayBackend, xy: np.ndarray) -> np.ndarray:
    """`probe_ground_z` for many points (K, 2) at once: (K,) heights, NaN where there is no
    terrain or water below. Each layer is one batch of rays over the points still probing,
    so K points cost as many casts as the deepest of them passes surfaces."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    ground = np.full(len(xy), np.nan)
    z = np.full(len(xy), PROBE_TOP_Z)
    probing = np.arange(len(xy))
    for _ in range(PROBE_MAX_LAYERS):
        if not len(probing):
            break
        origins = np.column_stack([xy[probing], z[probing]])
        hits = backend.cast(origins, np.tile([0.0, 0.0, -1.0], (len(probing), 1)), 2 * PROBE_TOP_Z)
        z_hit = z[probing] - hits.distance
        found = np.isin(hits.class_id, (*STANDING_IDS, WATER_ID)) & np.isfinite(hits.distance)
        ground[probing[found]] = z_hit[found]
        go_on = ~found & np.isfinite(hits.distance)
        z[probing[go_on]] = z_hit[go_on] - PROBE_STEP
        probing = probing[go_on]
    return ground


def cast_lasers(backend: RayBackend, pose: Pose, z_start: float) -> tuple[LaserHit, ...]:
    return lasers_of(pose, cast_lasers_many(backend, [pose], np.array([z_start]))[0])


def cast_lasers_many(backend: RayBackend, poses, z_starts: np.ndarray):
    """The four lasers of many poses in one batch of rays: RayHits of (K, 4) rays, one row a
    pose (`lasers_of` turns a row into LaserHits)."""
    xy = np.concatenate([laser_xy(pose) for pose in poses]) if len(poses) else np.zeros((0, 2))
    origins = np.column_stack([xy, np.repeat(np.asarray(z_starts, dtype=np.float64), len(LASERS))])
    down = np.tile([0.0, 0.0, -1.0], (len(origins), 1))
    hits = backend.cast(origins, down, 2 * PROBE_TOP_Z)
    count = len(LASERS)
    return [
        (
            origins[i : i + count],
            hits.distance[i : i + count],
            hits.class_id[i : i + count],
            hits.instance[i : i + count],
        )
        for i in range(0, len(origins), count)
    ]


def lasers_of(pose: Pose, row) -> tuple[LaserHit, ...]:
    """The LaserHits of one pose from its row of `cast_lasers_many`."""
    origins, distance, class_id, instance = row
    return tuple(
        LaserHit(
            name=name,
            origin=tuple(float(v) for v in origins[i]),
            distance=float(distance[i]),
            class_id=int(class_id[i]),
            instance=int(instance[i]),
        )
        for i, (name, _, _) in enumerate(LASERS)
    )


def enclosing_element(backend: RayBackend, centre: np.ndarray, yaw_deg: float) -> str | None:
    """The class name of an element around `centre` in all four arm directions within
    ENCLOSED_REACH (the sensor would be inside it), or None."""
    heading = rot_z(dm.radians(yaw_deg))
    dirs = dm.apply(heading, np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]]))
    hits = backend.cast(np.asarray(centre, dtype=np.float64), dirs, ENCLOSED_REACH)
    if hits.hit.all() and len(set(zip(hits.class_id.tolist(), hits.instance.tolist()))) == 1:
        return BY_ID[int(hits.class_id[0])].name
    return None


def place(backend: RayBackend, pose: Pose, z_start: float | None = None) -> Placement:
    """Stand the structure at `pose`; raise PoseRejected naming each laser that says no."""
    pose.validate()
    if z_start is None:
        ground = probe_ground_z(backend, pose.x, pose.y)
        if ground is None:
            raise PoseRejected(f"{describe_pose(pose)} {NO_GROUND}")
        z_start = ground + LASER_CLEARANCE
    else:
        check_z_start(z_start)
    placement = stand(pose, z_start, cast_lasers(backend, pose, z_start))
    enclosing = enclosing_element(backend, placement.optical_centre, pose.yaw_deg)
    if enclosing is not None:
        raise PoseRejected(
            f"{describe_pose(pose)} rejected: the sensor would stand inside a {enclosing} (its column "
            "meets it)"
        )
    return placement


def describe_pose(pose: Pose) -> str:
    return f"pose ({pose.x:g}, {pose.y:g}, yaw {pose.yaw_deg:g})"


def stand(pose: Pose, z_start: float, lasers: tuple[LaserHit, ...]) -> Placement:
    """The placement the four laser hits give (cast from `z_start`), or PoseRejected saying why
    the robot cannot stand there. Many poses share it: `place` casts for one, a drive for all."""
    where = describe_pose(pose)
    bad = [laser for laser in lasers if laser.class_id not in STANDING_IDS]
    if bad:
        if all(laser.class_id < 0 for laser in lasers):
            raise PoseRejected(
                f"{where} rejected: all four lasers hit nothing from z={z_start:g} (off the world?)"
            )
        raise PoseRejected(
            f"{where} rejected: "
            + "; ".join(laser.describe() for laser in bad)
            + " (all four must hit terrain or flooring)"
        )

    z_front, z_rear, z_left, z_right = (laser.hit_z for laser in lasers)
    unevenness = abs((z_front + z_rear) - (z_left + z_right)) / 2
    if unevenness > MAX_UNEVENNESS:
        raise PoseRejected(
            f"{where} rejected: the ground under the footprint is uneven (the arms' mid-heights differ by "
            f"{unevenness:.2f} m, at most {MAX_UNEVENNESS:g} m)"
        )
    roll, pitch = roll_pitch_from_slopes((z_front - z_rear) / (2 * ARM_X), (z_left - z_right) / (2 * ARM_Y))
    tilt = tilt_deg(roll, pitch)
    if tilt > MAX_TILT_DEG:
        raise PoseRejected(
            f"{where} rejected: the ground tilts {tilt:.1f} deg (roll {dm.degrees(roll):.1f}, pitch "
            f"{dm.degrees(pitch):.1f}); at most {MAX_TILT_DEG:g} deg"
        )
    ground_centre = np.array([pose.x, pose.y, (z_front + z_rear + z_left + z_right) / 4])
    column = dm.apply(
        sensor_to_world_matrix(roll, pitch, dm.radians(pose.yaw_deg)), [0.0, 0.0, COLUMN_HEIGHT]
    )
    return Placement(
        pose=pose,
        optical_centre=ground_centre + column,
        ground_centre=ground_centre,
        roll_rad=roll,
        pitch_rad=pitch,
        lasers=lasers,
    )
