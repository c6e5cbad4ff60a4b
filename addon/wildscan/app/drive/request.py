"""What a drive asks for, checked whole before a world is opened or built."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ...core.checks import one_of, whole_number
from ...core.errors import UserError
from ...core.motion.imu_models import DEFAULT_IMU, DEFAULT_RATE, check_imu, check_rate
from ...core.motion.timing import check_head
from ...core.motion.trajectory import DEFAULT_SPEED, check_speed
from ...core.placement import check_z_start
from ...core.sensor import SensorConfig
from ...core.spatial.frames import check_frame
from ...core.world import DEFAULT_VEGETATION, check_vegetation

BAGS = ("both", "ros1", "ros2", "none")
IMU_NOISE = ("on", "off")
ROS2_STORAGES = ("mcap", "sqlite3")
DRIVE_BACKENDS = ("auto", "embree", "bvh")  # they cast against triangles: one crop for the whole path
MAX_WIND_DEG = 10.0
MAX_SCANS_3D = 10_000


@dataclass(frozen=True)
class DriveRequest:
    out: str
    world: str | None = None  # a .blend file
    seed: int | None = None  # or a seed's world, planned without Blender
    detail: str = "default"
    vegetation: str = DEFAULT_VEGETATION  # of the seed's world (a .blend has its own)
    trail: bool = False  # the path: the world's trail,
    waypoints: str | None = None  # a CSV of x,y,
    start: tuple[float, float, float] | None = None  # or straight ahead from (x, y, yaw)
    distance: float | None = None  # ... for this many metres
    speed: float = DEFAULT_SPEED
    scans: int | None = None  # 3D scans to take (default: as many as the path allows)
    head: str = "stepped"
    sensor: SensorConfig = field(default_factory=SensorConfig)
    frame: str = "sensor"
    backend: str = "auto"
    bag: str = "both"
    ros2_storage: str = "mcap"
    wind: float = 0.0  # peak sway of the treetops, degrees (0: no wind)
    wind_seed: int = 0
    weather: dict | None = None  # key -> value (core/effects/weather.py); None or {}: clear air
    z_start: float | None = None  # where the placement lasers start (under a roof), or probed
    imu: str = DEFAULT_IMU  # an IMU model (core/motion/imu_models.py) or "none"
    imu_rate: int = DEFAULT_RATE  # Hz
    imu_noise: str = "on"  # "off": the exact readings
    quiet: bool = False  # no progress, nor Blender's "Read blend" line

    @property
    def bags(self) -> tuple[str, ...]:
        return {"both": ("ros1", "ros2"), "none": ()}.get(self.bag, (self.bag,))

    def check(self) -> "DriveRequest":
        """UserError naming the first setting that is wrong."""
        if (self.world is None) == (self.seed is None):
            raise UserError("give exactly one of {world} FILE.blend or {seed} S", related=("world", "seed"))
        kinds = [self.trail, self.waypoints is not None, self.start is not None]
        if sum(kinds) != 1:
            raise UserError(
                "give exactly one path: {trail}, {waypoints} PATH.csv or {from} X Y YAW {distance} M",
                related=("trail", "waypoints", "from", "distance"),
            )
        if (self.start is not None) != (self.distance is not None):
            raise UserError("{from} X Y YAW and {distance} M go together", related=("from", "distance"))
        check_speed(self.speed)
        check_z_start(self.z_start)
        if self.scans is not None:
            whole_number(self.scans, "scans", 1, MAX_SCANS_3D)
        check_head(self.head)
        self.sensor.validate()
        check_paper_model(self.sensor)
        if self.sensor.device.head is not None:  # the drive's sweep turns one head: the device's
            raise UserError(
                f"{self.sensor.device.id}: a device on a [head] scans with `wildscan scan` and datasets only "
                "so far, not in a drive",
                setting="device",
            )
        check_vegetation(self.vegetation)
        check_frame(self.frame)
        one_of(self.backend, "backend", DRIVE_BACKENDS)
        one_of(self.bag, "bag", BAGS)
        one_of(self.ros2_storage, "ros2_storage", ROS2_STORAGES)
        check_imu(self.imu)
        check_rate(self.imu_rate)
        one_of(self.imu_noise, "imu_noise", IMU_NOISE)
        if not math.isfinite(self.wind) or not 0 <= self.wind <= MAX_WIND_DEG:
            raise UserError(
                f"must be from 0 (no wind) to {MAX_WIND_DEG:g} degrees, got {self.wind:g}",
                setting="wind",
                allowed=(0, MAX_WIND_DEG),
            )
        if self.bags:
            from ...core.io.rosbag import require_rosbags

            require_rosbags()
        return self

    def to_dict(self) -> dict:
        return {
            "world": self.world,
            "seed": self.seed,
            "detail": self.detail if self.seed is not None else None,
            "vegetation": self.vegetation if self.seed is not None else None,
            "path": "trail" if self.trail else "waypoints" if self.waypoints is not None else "straight",
            "waypoints": self.waypoints,
            "from": list(self.start) if self.start is not None else None,
            "distance": self.distance,
            "speed": self.speed,
            "scans": self.scans,
            "head": self.head,
            "sensor": self.sensor.to_dict(),
            "frame": self.frame,
            "backend": self.backend,
            "bag": self.bag,
            "ros2_storage": self.ros2_storage,
            "wind": self.wind,
            "wind_seed": self.wind_seed,
            "imu": self.imu,
            "imu_rate": self.imu_rate,
            "imu_noise": self.imu_noise,
            **({"weather": dict(self.weather)} if self.weather else {}),  # clear air: the same dict
        }


def check_paper_model(sensor: SensorConfig) -> None:
    """A drive emulates the paper model only: its sweep (core/motion/sweep.py) casts one thin
    ray a beam at the beam's own time and pose, and the realistic model's footprint and
    echoes are not worked out for a moving head."""
    if sensor.realistic:
        raise UserError(
            "must be paper: a drive emulates the paper sensor model only (one thin ray a beam, one "
            "echo); for echoes use `wildscan scan --model realistic` or `wildscan dataset`",
            setting="model",
            allowed=("paper",),
        )
