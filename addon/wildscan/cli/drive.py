"""`wildscan drive`: argument parsing only (the work is in app/drive)."""

from __future__ import annotations

import argparse
import sys

from ..app.drive.request import MAX_SCANS_3D
from ..core.checks import whole_number
from ..core.errors import UserError
from ..core.motion.imu_models import DEFAULT_IMU, DEFAULT_RATE, IMU_CHOICES, MAX_RATE, MIN_RATE, MODELS
from ..core.motion.timing import HEAD_MODES
from ..core.motion.trajectory import DEFAULT_SPEED, MAX_SPEED
from . import options
from .options import ArgumentParser, finite_float, non_negative_int

HELP = (
    "drive the robot along a path while the head turns: timed raw and deskewed clouds, trajectory, IMU, "
    "ROS bags"
)
DESCRIPTION = (
    "Drive the robot at constant speed along the world's trail, through waypoints or straight ahead, "
    "standing on the ground at every 2D scan as the four placement lasers say, while the 2D scanner sweeps "
    "every 25 ms and the head turns r_h per 2D scan. Every beam has its own time and pose. Writes into DIR, "
    "per 3D scan, the raw cloud (as a driver gives it) and the deskewed cloud (every point where it is) as "
    "PLY with a per-point time, a SemanticKITTI sequence of the deskewed scans, the ground-truth trajectory "
    "(TUM), an IMU's samples (imu.csv, /imu), the scans within 3 m of each other (revisits.json) and ROS 1 / "
    "ROS 2 bags (docs/motion.md)."
)


# A drive emulates the paper model only (app/drive/request.py check_paper_model says why).
DRIVE_OVERRIDES = {
    "model": dict(
        help="sensor model: paper only (default). A drive emulates the paper model: one thin ray a beam, "
        "cast at the beam's own time and pose; realistic (footprint, echoes) is refused with exit 2, "
        "use `wildscan scan` or `wildscan dataset` for it"
    ),
}


def scans_count(text: str) -> int:
    """--scans: the one range the request checks too (app/drive/request.py)."""
    try:
        return whole_number(text, "", 1, MAX_SCANS_3D)
    except UserError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def imu_rate(text: str) -> int:
    """--imu-rate: the one range the request checks too (core/motion/imu_models.py)."""
    try:
        return whole_number(text, "", MIN_RATE, MAX_RATE)
    except UserError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def add_imu(p: ArgumentParser) -> None:
    models = ", ".join(f"{name} ({model.title})" for name, model in MODELS.items())
    p.add_argument(
        "--imu",
        choices=IMU_CHOICES,
        default=DEFAULT_IMU,
        help=f"the IMU on the robot, its noise and biases from its datasheet: {models}, or none "
        f"(default {DEFAULT_IMU}): sensor_msgs/Imu on /imu in the bags and DIR/imu.csv",
    )
    p.add_argument(
        "--imu-rate",
        type=imu_rate,
        default=DEFAULT_RATE,
        metavar="HZ",
        help=f"IMU samples a second, {MIN_RATE} to {MAX_RATE} (default {DEFAULT_RATE})",
    )
    p.add_argument(
        "--imu-noise",
        choices=("on", "off"),
        default="on",
        help="on: the datasheet's white noise and biases (default); off: the exact readings",
    )


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    source = p.add_mutually_exclusive_group(required=True)
    options.add(p, "world", group=source, help="drive in this saved world (needs bpy)")
    options.add(p, "seed", group=source, help="drive in the world of this seed, planned without Blender")
    options.add(p, "detail", help="detail level of the --seed world: low | default | high (default: default)")
    options.add(p, "vegetation", default=None, help=f"with --seed: {options.VEGETATION_HELP}")
    route = p.add_mutually_exclusive_group(required=True)
    route.add_argument("--trail", action="store_true", help="drive along the world's trail, from its start")
    route.add_argument(
        "--waypoints", metavar="PATH.csv", help="drive through these waypoints: one `x,y` a line, metres"
    )
    route.add_argument(
        "--from",
        dest="start",
        nargs=3,
        type=finite_float,
        metavar=("X", "Y", "YAW"),
        help="drive straight ahead from X, Y (metres) heading YAW (degrees CCW from +X); with --distance",
    )
    p.add_argument("--distance", type=finite_float, metavar="M", help="how far to drive from --from, metres")
    p.add_argument(
        "--speed",
        type=finite_float,
        default=DEFAULT_SPEED,
        metavar="M/S",
        help=f"constant speed, 0 (standing still) to {MAX_SPEED:g} m/s (default {DEFAULT_SPEED:g})",
    )
    p.add_argument(
        "--scans",
        type=scans_count,
        metavar="N",
        help=f"3D scans to take, 1 to {MAX_SCANS_3D} (default: as many as fit along the path; 1 standing "
        "still)",
    )
    options.add(
        p,
        "z_start",
        help="world height in metres where the four downward placement lasers start at every instant "
        "of the drive, as `wildscan scan --z-start` at its pose: give one under an overhang to drive "
        "inside the cave (`wildscan poses --zone cave` lists one per pose); it must stay above the "
        "ground and under the roof along the path. Default: found at every instant by a probe from "
        "above (the first terrain surface: over a paper world's cave its roof; where the biome covers "
        "the ground the roof is rock and the probe finds the cave's floor)",
    )
    p.add_argument(
        "--head",
        choices=HEAD_MODES,
        default="stepped",
        help="stepped: the head stands still during each 2D scan and steps r_h between them, as Eq. 1 "
        "(default); continuous: it turns steadily, each beam at the head angle of its own time",
    )
    from .sensors import add_sensor, device_default

    add_sensor(p)
    for name in options.SENSOR_OPTIONS:
        if name not in options.REALISTIC_ONLY:
            options.add(p, name, **{**device_default(name), **DRIVE_OVERRIDES.get(name, {})})
    options.add(
        p,
        "frame",
        default="sensor",
        help="frame of both clouds of a 3D scan, at its start: sensor (default; as a driver gives the raw "
        "cloud), leveled or world",
    )
    options.add(p, "backend", choices=("auto", "embree", "bvh"), help="ray caster (default auto)")
    p.add_argument(
        "--wind",
        type=finite_float,
        default=0.0,
        metavar="DEG",
        help="wind: treetops sway up to DEG degrees about their base, bushes and grass more (0, the "
        "default, is still air)",
    )
    p.add_argument("--wind-seed", type=non_negative_int, default=0, metavar="N", help="seed of the sway (0)")
    from .weather import add_weather

    add_weather(p)
    options.add(p, "out", metavar="DIR", help="folder to write into (created if missing)")
    p.add_argument(
        "--bag",
        choices=("both", "ros1", "ros2", "none"),
        default="both",
        help="ROS bags to write: ros1 (DIR/drive.bag), ros2 (DIR/drive_ros2/), both (default) or none",
    )
    p.add_argument(
        "--ros2-storage",
        choices=("mcap", "sqlite3"),
        default="mcap",
        help="storage of the ROS 2 bag (default mcap)",
    )
    add_imu(p)
    p.add_argument("--quiet", action="store_true", help="no progress, only the summary")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app.drive import DriveRequest, Interrupted, run_drive
    from .output import Progress

    same = ("out", "world", "seed", "detail", "trail", "waypoints", "distance", "speed", "scans", "head")
    same += ("frame", "backend", "bag", "ros2_storage", "wind", "wind_seed", "weather", "z_start", "quiet")
    same += ("imu", "imu_rate", "imu_noise")
    request = DriveRequest(
        **{name: getattr(args, name) for name in same},
        start=tuple(args.start) if args.start is not None else None,
        sensor=options.sensor_of(args),
        vegetation=options.vegetation_of(args),
    )
    try:
        report = run_drive(request, progress=Progress("driving", args.quiet), say=print)
    except Interrupted as e:
        sys.stderr.write(f"wildscan drive: {e}\n")
        return e.code
    points = sum(report.points)
    print(
        f"drove {report.distance:.2f} m in {report.duration:.2f} s: {report.scans_2d:,} "
        f"{request.sensor.device.columns_named}, "
        f"{report.scans_3d} 3D scans ({points:,} points); wrote {len(report.files)} files into {report.out} "
        f"in {report.total_seconds:.1f} s"
    )
    if args.imu != "none":
        print(f"  imu: {args.imu} at {args.imu_rate} Hz, noise {args.imu_noise} (imu.csv)")
    for flavour, counts in report.bag_counts.items():
        topics = ", ".join(f"{topic} {n:,}" for topic, n in counts.items())
        print(f"  {flavour} bag: {topics}")
    return 0
