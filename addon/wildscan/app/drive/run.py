"""`wildscan drive`: place the robot at every 2D scan of its path, sweep, write.

The work is batched: one crop of the world around the whole path and one ray caster over
it, the placements of every 2D scan in a few batches of rays, and the beams of each 3D
scan in large casts (sweep.py); Python loops only over 3D scans and, to write the bags,
over 2D scans.
"""

from __future__ import annotations

import time
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ... import __version__
from ...core.backend import RayBackend
from ...core.classes import class_table_dict
from ...core.effects import Effects
from ...core.io.tum import tum_text
from ...core.io.writer import ScanOutput
from ...core.label_schemes import scheme
from ...core.motion.placements import Motion, place_all
from ...core.motion.sweep import Sweep, sweep
from ...core.motion.trajectory import instants, schedule
from ...core.rng import seeded
from ...core.scan import points_in_frame
from ...core.spatial.reach import check_reach
from ...core.truth.groundtruth import pose_matrix
from ...core.truth.revisits import revisits, revisits_document, revisits_json
from ...raycast.wind import drive_effects, moving_scene
from ..interrupts import Interrupted, Terminated, sigterm_raises
from ..scan import crop_radius
from . import files
from .bags import BagFeed, open_bags
from .imu import IMU_CSV, drive_imu
from .memory import keep_freed_memory
from .request import DriveRequest
from .world import drive_path, drive_world


@dataclass
class DriveReport:
    out: Path
    files: list[str]
    scans_2d: int
    scans_3d: int
    duration: float  # s of driving
    distance: float  # m driven
    points: list[int]  # per 3D scan
    bag_counts: dict[str, dict[str, int]]
    seconds: dict[str, float] = field(default_factory=dict)  # stage -> wall time

    @property
    def total_seconds(self) -> float:
        return sum(self.seconds.values())


def run_drive(request: DriveRequest, progress=None, say=print) -> DriveReport:
    """Drive as `request` says and write its files into `request.out` (docs/motion.md).
    `progress(done, total)` hears of the rays cast; `say` gets one-line news. SIGTERM ends it
    as Ctrl-C does, with Interrupted (code 143); either way nothing is left in the folder."""
    try:
        with sigterm_raises():
            return _drive(request, progress, say)
    except Terminated:
        raise Interrupted("terminated; nothing written", 143) from None


def _drive(request: DriveRequest, progress, say) -> DriveReport:
    keep_freed_memory()  # the sweeps' arrays reuse heap pages instead of faulting in new ones
    clock = _Clock()
    request.check()
    files.check_out_dir(request.out)
    path = None if request.trail else drive_path(request, None)  # a bad CSV is found before the world
    world = drive_world(request)
    path = path or drive_path(request, world.trail)
    sensor = request.sensor
    period = sensor.device.timing.column_period_s
    plan = schedule(path, request.speed, sensor.sweeps, request.scans, period, sensor.device.columns_named)
    clock.lap("world")

    times, xy, yaw = instants(path, request.speed, plan.scans_2d + 1, period)
    effects = drive_effects(request.wind, request.wind_seed)
    if request.weather or world.cover is not None:  # every ray draws its own particles, its sward depth
        from ..scan import scan_effects

        effects = Effects(effects.items + scan_effects(request.weather, sensor, world.cover).items)
    backend = _backend(request, effects, world.crop(xy, crop_radius(sensor)), say)
    clock.lap("crop")
    starts = range(0, plan.scans_2d, plan.sweeps)  # the 3D scans' first 2D scans: their metadata
    motion = place_all(backend, times, xy, yaw, request.speed * times, request.z_start, keep=starts)
    check_reach(motion.centre, sensor.max_range, request.frame, backend.name)
    clock.lap("placement")
    imu = drive_imu(
        motion,
        sensor.device.timing.column_period_ns,
        plan.scans_2d,
        request.imu,
        request.imu_rate,
        request.imu_noise == "on",
        int(sensor.noise_seed),
    )
    clock.lap("imu")

    from ...core.io.files import output_directory

    context = _Context(request, world.provenance, motion, world.instances, backend, imu)
    stage = files.Staging(output_directory(request.out))
    try:
        with ExitStack() as bags:
            opened = open_bags(bags, stage, request.bags, request.ros2_storage, imu is not None)
            feed = BagFeed(opened, motion, sensor, imu)
            feed.static()
            counter = _Rays(progress, plan.scans_2d * sensor.beams_per_column)
            points = []
            for k0, k1 in _groups(plan.scans_2d, plan.sweeps):
                noise = context.noise(k1 - k0)
                result = sweep(
                    backend, motion, k0, k1, sensor, request.head, noise, "sensor", counter, effects
                )
                clock.lap("sweep")
                whole = k1 - k0 == plan.sweeps
                if whole:
                    points.append(context.write_scan(stage, k0 // plan.sweeps, result))
                feed.scans(result, last=k1 == plan.scans_2d)
                if whole:
                    feed.clouds(result)
                clock.lap("write")
        context.finish(stage, plan, path, feed.counts())
        written = stage.commit()
        clock.lap("write")
    finally:
        stage.discard()  # after a commit there is nothing left to discard
    return DriveReport(
        out=stage.root,
        files=written,
        scans_2d=plan.scans_2d,
        scans_3d=plan.scans_3d,
        duration=plan.duration,
        distance=float(motion.distance[-1]),
        points=points,
        bag_counts=feed.counts(),
        seconds=clock.laps,
    )


def _backend(request: DriveRequest, effects: Effects, cropped, say) -> RayBackend:
    from ...raycast.select import make_backend

    if effects.scene_mover is None:
        return make_backend(request.backend, geometry=cropped, notify=say)
    name = make_backend(request.backend, geometry=cropped.subset(np.zeros(0, dtype=int)), notify=say).name

    def make(geometry):
        return make_backend(name, geometry=geometry, notify=None)

    return moving_scene(cropped, effects, make, request.sensor)


def _groups(scans_2d: int, sweeps: int) -> list[tuple[int, int]]:
    """The 3D scans' runs of 2D scans, then the 2D scans after the last whole 3D scan."""
    edges = list(range(0, scans_2d, sweeps)) + [scans_2d]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:])]


class _Context:
    """What every file of one drive shares, and writing them."""

    def __init__(
        self,
        request: DriveRequest,
        provenance: dict,
        motion: Motion,
        instances,
        backend: RayBackend,
        imu=None,
    ):
        self.request = request
        self.imu = imu
        self.provenance = provenance
        self.motion = motion
        self.world_instances = np.unique(np.asarray(instances))
        self.backend_name = backend.name
        self.labels = scheme("semantickitti")
        sigma = request.sensor.fixed_noise  # the paper model's 0.015 m unless --noise says otherwise
        # one generator for the drive: the first 3D scan draws what a static scan draws
        self._rng = seeded(int(request.sensor.noise_seed)) if sigma > 0 else None
        self.pose_matrices: list[np.ndarray] = []
        self.start_times: list[float] = []
        self.start_centres: list[np.ndarray] = []  # each 3D scan's optical centre at its start
        self.scans: list[dict] = []
        self.class_points = np.zeros(max(self.labels.labels) + 1)

    def noise(self, scans_2d: int) -> np.ndarray:
        count = scans_2d * self.request.sensor.beams_per_column
        if self._rng is None:
            return np.zeros(count)
        return self.request.sensor.fixed_noise * self._rng.standard_normal(count)

    def metadata(self, index: int, result: Sweep, cloud: str) -> dict:
        start = self.motion.placement(result.k0)
        request = self.request
        return {
            "wildscan_version": __version__,
            "seed": self.provenance["seed"],
            "world": self.provenance["world"],
            "pose": start.pose.to_dict(),
            "frame": request.frame,
            "sensor": request.sensor.to_dict(),
            "backend": self.backend_name,
            "placement": start.to_dict(),
            "drive": {
                "cloud": cloud,
                "scan": index,
                "first_2d_scan": result.k0,
                "start_time": float(self.motion.times[result.k0]),
                "end_time": float(self.motion.times[result.k1]),
                "speed": request.speed,
                "head": request.head,
                "wind": request.wind,
            },
            "classes": class_table_dict(particles=bool(request.weather)),
        }

    def write_scan(self, stage: files.Staging, index: int, result: Sweep) -> int:
        """The raw and deskewed PLY files of 3D scan `index` and its SemanticKITTI files
        (the format table's writers, core/io/formats.py)."""
        start = self.motion.placement(result.k0)
        paths = files.scan_files(index)
        frame = self.request.frame
        clouds = {}
        for kind, cloud in (("raw", result.raw), ("deskewed", result.deskewed)):
            clouds[kind] = replace(cloud, xyz=points_in_frame(cloud.xyz, start, frame), frame=frame)
            scan = ScanOutput(clouds[kind], self.metadata(index, result, kind), self.labels)
            ply = {"ply": paths[kind], "ply_sidecar": paths[f"{kind}_sidecar"]}
            files.stage_format(stage, "ply", scan, ply)
        deskewed = clouds["deskewed"]
        scan = ScanOutput(deskewed, {}, self.labels, world_instances=self.world_instances)
        kitti = {"velodyne": paths["velodyne"], "labels": paths["labels"]}
        files.stage_format(stage, "semantickitti", scan, kitti)
        self.class_points += np.bincount(self.labels.map(deskewed.label), minlength=len(self.class_points))
        self.pose_matrices.append(pose_matrix(start, frame))
        self.start_times.append(float(self.motion.times[result.k0]))
        self.start_centres.append(self.motion.centre[result.k0])
        self.scans.append(
            {
                "scan": index,
                "first_2d_scan": result.k0,
                "start_time": float(self.motion.times[result.k0]),
                "points": len(deskewed),
                "files": paths,
            }
        )
        return len(deskewed)

    def finish(self, stage: files.Staging, plan, path, bag_counts: dict) -> None:
        """The files about the whole drive: trajectory, SemanticKITTI sequence files, drive.json."""
        from ...core.io.semantickitti import label_config_yaml

        motion = self.motion
        count = plan.scans_2d
        comment = "WildScan drive: the sensor (optical centre, sensor frame) in the world frame, per 2D scan"
        tum = tum_text(motion.times[:count], motion.centre[:count], motion.rotation[:count], comment)
        stage.write(files.TRAJECTORY, tum.encode())
        # the IMU's extrinsics to the scans' frame: fixed in the sensor frame only
        imu_to_velo = (
            self.imu.sensor_from_imu() if self.imu is not None and self.request.frame == "sensor" else None
        )
        files.kitti_sequence(stage, self.pose_matrices, self.start_times, imu_to_velo)
        if self.imu is not None:
            stage.write(IMU_CSV, self.imu.csv_text().encode())
        stage.write(files.REVISITS_JSON, revisits_json(self.revisits()).encode())
        total = self.class_points.sum()
        content = {k: float(self.class_points[k] / total) if total else 0.0 for k in self.labels.labels}
        splits = {"train": [0], "valid": [], "test": []}
        weather = bool(self.request.weather)
        config = label_config_yaml(self.labels, content, splits, "WildScan drive", particles=weather)
        stage.write("labels.yaml", config.encode())
        listed = stage.files() + [files.DRIVE_JSON]
        summary = {
            "wildscan_version": __version__,
            "request": self.request.to_dict(),
            "world": self.provenance,
            "backend": self.backend_name,
            "path": {"kind": path.kind, "length": path.length},
            "scans_2d": count,
            "scans_3d": plan.scans_3d,
            "sweeps_per_3d_scan": plan.sweeps,
            "duration": plan.duration,
            "distance": float(motion.distance[-1]),
            "scans": self.scans,
            "bags": bag_counts,
            "imu": self.imu.to_dict() if self.imu is not None else None,
            "files": sorted(listed),
        }
        stage.write(files.DRIVE_JSON, files.json_bytes(summary))

    def revisits(self) -> dict:
        """revisits.json: the 3D scans that see the same place (core/revisits.py)."""
        xy = np.array(self.start_centres).reshape(-1, 3)[:, :2]
        ids = "3D scan index: NNNNNN of its files, its line of sequences/00/poses.txt and times.txt"
        return revisits_document({"00": revisits(xy, self.start_times)}, ids)


class _Rays:
    """Progress in rays cast over the whole drive."""

    def __init__(self, progress, total: int):
        self.progress, self.total, self.done = progress, total, 0

    def __call__(self, rays: int) -> None:
        self.done += rays
        if self.progress is not None:
            self.progress(self.done, self.total)


class _Clock:
    def __init__(self):
        self.laps: dict[str, float] = {}
        self.t = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.laps[stage] = self.laps.get(stage, 0.0) + now - self.t
        self.t = now
