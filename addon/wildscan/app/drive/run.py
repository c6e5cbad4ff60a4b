"""`wildscan drive`: place the robot at every 2D scan of its path, sweep, write.

The work is batched: one crop of the world around the whole path and one ray caster over
it, the placements of every 2D scan in a few batches of rays, and the beams of each 3D
scan in large casts (sweep.py); Python loops only over 3D scans and, to write the bags,
over 2D scans.
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait
from contextlib import ExitStack, closing
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ... import __version__
from ...core.backend import RayBackend
from ...core.classes import class_table_dict, ids_present, listed_classes
from ...core.effects import Effects
from ...core.io.tum import tum_text
from ...core.io.writer import ScanOutput
from ...core.label_schemes import scheme
from ...core.motion.placements import Motion, motion_of, place_all
from ...core.motion.sweep import Sweep, beams_of, sweep
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
from .ahead import one_ahead
from .bags import BagFeed, open_bags
from .imu import IMU_CSV, drive_imu
from .memory import keep_freed_memory, one_heap
from .request import DriveRequest
from .trails import TrailWorld, pieces, trail_world
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


def run_drive(request: DriveRequest, progress=None, say=print, cache=None) -> DriveReport:
    """Drive as `request` says and write its files into `request.out` (docs/motion.md);
    `cache`: the world cache an endless drive keeps its tiles in (DiskCache or None).
    `progress(done, total)` hears of the rays cast; `say` gets one-line news. SIGTERM ends it
    as Ctrl-C does, with Interrupted (code 143); either way nothing is left in the folder."""
    try:
        with sigterm_raises():
            return _drive(request, progress, say, cache)
    except Terminated:
        raise Interrupted("terminated; nothing written", 143) from None


def _drive(request: DriveRequest, progress, say, cache) -> DriveReport:
    keep_freed_memory()  # the sweeps' arrays reuse heap pages instead of faulting in new ones
    one_heap()  # and the drive's threads share one heap (memory.py)
    clock = _Clock()
    request.check()
    files.check_out_dir(request.out)
    path = None if request.trail else drive_path(request, None)  # a bad CSV is found before the world
    world = trail_world(request, cache) if request.long_trail else drive_world(request)
    if path is None:
        path = (
            world.route(request.distance, request.route)
            if request.long_trail
            else drive_path(request, world.trail)
        )
    sensor = request.sensor
    period = sensor.device.timing.column_period_s
    plan = schedule(path, request.speed, sensor.sweeps, request.scans, period, sensor.device.columns_named)
    clock.lap("world")

    times, xy, yaw = instants(path, request.speed, plan.scans_2d + 1, period)
    runs = pieces(plan.scans_2d, plan.sweeps, request.speed * period, request.long_trail)
    reach = crop_radius(sensor)
    motions, backend, backend_name = [], None, None

    def ground(run):  # the robot stood on each piece's own triangles (the sweep's, below)
        k0, k1 = run
        return _piece_backend(request, world, xy[k0 : k1 + 1], reach, say if k0 == 0 else None, len(runs) > 1)

    with closing(one_ahead(ground, runs)) as grounds:
        for k0, k1 in runs:
            backend, effects = next(grounds)
            backend_name = backend_name or backend.name
            clock.lap("crop")  # the wait for the piece's ground, made while the last was placed
            motions.append(_placed(request, sensor, plan, backend, times, xy, yaw, k0, k1))
            clock.lap("placement")
            if len(runs) > 1:
                backend = None  # built again for its sweeps: the placements of every piece come first (IMU)
    motion = joined_motion(motions, [k0 for k0, _ in runs])
    check_reach(motion.centre, sensor.max_range, request.frame, backend_name)
    imu = drive_imu(
        motion,
        sensor.device.timing.column_period_ns,
        plan.scans_2d,
        request.imu,
        request.imu_rate,
        request.imu_noise == "on",
        int(sensor.noise_seed),
        sensor.mount_height,
    )
    clock.lap("imu")

    from ...core.io.files import output_directory

    context = _Context(request, world.provenance, motion, world.instances, backend_name, effects.classes, imu)
    stage = files.Staging(output_directory(request.out))
    try:
        with ExitStack() as bags:
            opened = open_bags(bags, stage, request.bags, request.ros2_storage, imu is not None)
            feed = BagFeed(opened, motion, sensor, imu)
            feed.static()
            counter = _Rays(progress, plan.scans_2d * sensor.beams_per_column)
            points = []
            behind = bags.enter_context(_Behind())  # closed before the bags: its last writes first

            def whole(run):  # a piece's world for its sweeps (the placement's was its ground)
                return _piece_backend(request, world, xy[run[0] : run[1] + 1], reach, None)

            worlds = bags.enter_context(closing(one_ahead(whole, runs if len(runs) > 1 else [])))
            groups = _groups(runs, plan.sweeps)

            def rays(group):  # the next sweep's noise and rays, made while this one casts
                k0, k1, _ = group
                return context.noise(k1 - k0), beams_of(motion, k0, k1, sensor, request.head)

            ready = bags.enter_context(closing(one_ahead(rays, groups)))
            for k0, k1, piece in groups:
                if piece is not None and len(runs) > 1:
                    backend = None  # the previous piece's triangles go as the next come
                    backend, effects = next(worlds)
                    clock.lap("crop")  # the wait for the piece's world, made while the last was swept
                noise, beams = next(ready)
                result = sweep(
                    backend, motion, k0, k1, sensor, request.head, noise, "sensor", counter, effects, beams
                )
                clock.lap("sweep")
                behind(_writes(context, stage, feed, points, result, plan))
                clock.lap("write")  # the wait for the previous sweep's files
            behind.wait()
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


def _placed(request: DriveRequest, sensor, plan, backend, times, xy, yaw, k0: int, k1: int) -> Motion:
    """The robot placed at the instants k0 ... k1 of the path on `backend`'s ground."""
    span = slice(k0, k1 + 1)
    distance = request.speed * times[span]
    keep = [s - k0 for s in range(k0, k1, plan.sweeps)]  # the 3D scans' first 2D scans: their metadata
    height = sensor.mount_height
    return place_all(backend, times[span], xy[span], yaw[span], distance, request.z_start, height, keep, k0)


def _piece_backend(request: DriveRequest, world, xy: np.ndarray, reach: float, say, placing: bool = False):
    """(the ray caster over the world's triangles within reach of the path `xy`, the drive's
    effects there: wind, weather, the ground cover: the world's, or an endless piece's own).
    `placing`: an endless piece's ground only, for the placement (the sweep's comes later)."""
    cropped = world.ground(xy, reach) if placing else world.crop(xy, reach)
    cover = cropped.cover if isinstance(world, TrailWorld) else world.cover
    effects = drive_scan_effects(request, cover)
    return _backend(request, effects, cropped, say), effects


def drive_scan_effects(request: DriveRequest, cover) -> Effects:
    """Wind, and the rays' own draws: particles of the weather, the sward's depth."""
    from ..scan import scan_effects

    effects = drive_effects(request.wind, request.wind_seed)
    # every ray draws its own particles, its sward depth: the effects table's and the cover
    found = scan_effects(request.weather, request.sensor, cover, request.effects)
    return Effects(effects.items + found.items)


def _backend(request: DriveRequest, effects: Effects, cropped, say) -> RayBackend:
    from ...raycast.select import make_backend

    if effects.scene_mover is None:
        return make_backend(request.backend, geometry=cropped, notify=say)
    name = make_backend(request.backend, geometry=cropped.subset(np.zeros(0, dtype=int)), notify=say).name

    def make(geometry):
        return make_backend(name, geometry=geometry, notify=None)

    return moving_scene(cropped, effects, make, request.sensor)


def _writes(context: _Context, stage: files.Staging, feed: BagFeed, points: list, result: Sweep, plan):
    """The files and bag messages of one sweep, in the order they were written in one thread."""
    whole = result.k1 - result.k0 == plan.sweeps

    def write() -> None:
        if whole:
            points.append(context.write_scan(stage, result.k0 // plan.sweeps, result))
        feed.scans(result, last=result.k1 == plan.scans_2d)
        if whole:
            feed.clouds(result)

    return write


class _Behind:
    """One sweep's writing (PLY, SemanticKITTI, the bags' messages) on a thread of its own
    while the next sweep is cast: the two take turns on the two cores instead of one waiting
    for the other (a 300 m drive spent 10.6 s of its 25 s writing). One write at a time, in
    the drive's order, so every file and bag gets the same bytes as written in line; at most
    one sweep's clouds wait (memory stays bounded)."""

    def __init__(self):
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="wildscan-drive-write")
        self._pending: Future | None = None

    def __call__(self, write) -> None:
        """`write()` begun once the previous one is done (its error raised here)."""
        self.wait()
        self._pending = self._pool.submit(write)

    def wait(self) -> None:
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def __enter__(self) -> _Behind:
        return self

    def __exit__(self, kind, value, trace) -> None:
        try:
            if kind is None:
                self.wait()
            elif self._pending is not None:  # interrupted: let the write end before the bags close
                futures_wait([self._pending])
        finally:
            self._pool.shutdown(wait=True)


def _groups(runs: list[tuple[int, int]], sweeps: int) -> list[tuple[int, int, tuple | None]]:
    """The 3D scans' runs of 2D scans, then the 2D scans after the last whole 3D scan; each
    with its piece of the world when it is the piece's first (None otherwise)."""
    out = []
    for a, b in runs:
        edges = list(range(a, b, sweeps)) + [b]
        out += [(k0, k1, (a, b) if k0 == a else None) for k0, k1 in zip(edges[:-1], edges[1:])]
    return out


def joined_motion(motions: list[Motion], firsts: list[int]) -> Motion:
    """The motions of consecutive pieces (starting at 2D scans `firsts`) as one: each piece's
    last instant is the next one's first (placed again there on the next piece's triangles),
    so it is taken from the next."""
    if len(motions) == 1:
        return motions[0]

    def joined(name: str) -> np.ndarray:
        return np.concatenate([getattr(m, name)[:-1] for m in motions[:-1]] + [getattr(motions[-1], name)])

    kept = {first + k: p for m, first in zip(motions, firsts) for k, p in m.kept.items()}
    names = ("times", "distance", "centre", "ground", "rotation")
    return motion_of(*(joined(name) for name in names), kept, joined("attitude"))


class _Context:
    """What every file of one drive shares, and writing them."""

    def __init__(
        self,
        request: DriveRequest,
        provenance: dict,
        motion: Motion,
        instances,
        backend_name: str,
        declared: tuple[int, ...],
        imu=None,
    ):
        self.request = request
        self.declared = declared  # the optional classes the drive's effects can produce (Effect.classes)
        self.carried: set[int] = set()  # the classes the drive's points carry, for labels.yaml
        self.imu = imu
        self.provenance = provenance
        self.motion = motion
        self.world_instances = np.unique(np.asarray(instances))
        self.backend_name = backend_name
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

    def metadata(self, index: int, result: Sweep, cloud: str, labels: np.ndarray) -> dict:
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
            "classes": class_table_dict(listed_classes(labels, self.declared)),
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
            scan = ScanOutput(clouds[kind], self.metadata(index, result, kind, cloud.label), self.labels)
            ply = {"ply": paths[kind], "ply_sidecar": paths[f"{kind}_sidecar"]}
            files.stage_format(stage, "ply", scan, ply)
        deskewed = clouds["deskewed"]
        scan = ScanOutput(deskewed, {}, self.labels, world_instances=self.world_instances)
        kitti = {"velodyne": paths["velodyne"], "labels": paths["labels"]}
        files.stage_format(stage, "semantickitti", scan, kitti)
        self.class_points += np.bincount(self.labels.map(deskewed.label), minlength=len(self.class_points))
        self.carried.update(ids_present(deskewed.label))
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
        classes = listed_classes(sorted(self.carried), self.declared)
        config = label_config_yaml(self.labels, content, splits, "WildScan drive", classes)
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
