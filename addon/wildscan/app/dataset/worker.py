"""What a Dask worker runs: one world seed with a batch of its scan indices.

The paper layout's world is planned once per worker (a small cache keeps it for the next
batch of the same world; the world cache on disk, app/cache/, keeps it for every worker and
run) and turned straight into triangles (the Blender-free path: no bpy), which
one Embree scene holds for every scan of that world: placement, the sweep and the
bird's-eye rays all cast against it, so nothing is cropped or rebuilt per pose (a
bird's-eye cell on open ground, where the terrain is the only surface, is not cast:
core/truth/open_ground.py). An endless world keeps its poses per worker, and each scan casts
against the tiles it reaches, from the process's tile memory, the world cache or built
(land.py LandWorld.for_scan). Every
file of a scan is written under a temporary name and renamed with the others only when
all of them are complete; the rows returned say what was written, with sizes and SHA-256.

File numbers are dense per sequence, as a SemanticKITTI loader expects: the scans that have
a pose are numbered 000000..N-1 in scan order (a scan without one has a manifest row and no
files), so line k of poses.txt is the pose of file k (WorldContext.file_numbers).
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
import time
from pathlib import Path

import numpy as np

from ... import __version__
from ...core.errors import PoseRejected, UserError
from ...core.io.files import atomic_outputs
from ...core.label_schemes import scheme
from ...core.placement import COLUMN_HEIGHT
from ...core.posesampler import NoPose
from ...core.runtime.cast_clock import CLOCK
from ...core.runtime.peak import peak_resident_bytes
from ...core.scan import run_scan
from ...core.truth.groundtruth import (
    bev_grid,
    height_above_ground,
    map_top_class,
    npy_bytes,
    pose_matrix,
    world_points,
)
from ...core.truth.traversability import class_height_histogram, support_flags
from ..cache.config import open_cache, world_facts
from ..cache.store import DiskCache
from ..tile_memory import TILE_WORK, TileWork
from .context import WorldContext, embree_backend
from .draws import draw_effects, draw_sensor, draw_weather
from .intensity import scan_intensity_facts, with_dataset_intensity
from .layout import scan_paths
from .spec import DatasetSpec, spec_from_json

RANGE_BIN = 0.5  # m, the range histogram kept per scan (dataset card)
RANGE_BINS = 60

# The worker's last world, kept for the next batch of the same world (a world's batches
# follow each other in the queue). One only, freed before the next is built: a porous world
# is most of a worker's memory, and holding a second while building would double its peak.
_last_world: dict[tuple, WorldContext] = {}


def _world_key(spec: DatasetSpec, seed: int) -> tuple:
    return (seed, spec.layout, spec.detail, spec.vegetation, spec.biome, spec.scans_per_world, spec.poses)


def world_context(spec: DatasetSpec, seed: int, cache: DiskCache | None = None, placed: list | None = None):
    """The world of `seed` ready to scan (a WorldContext; on the endless layout a LandWorld, its
    poses, each scan's tiles made by LandWorld.for_scan; `placed`: its poses as the run's pose
    task placed them, world_poses_task)."""
    _keep_freed_memory()
    key = _world_key(spec, seed)
    if key not in _last_world:
        _last_world.clear()
        if spec.layout == "endless":
            from .land import land_world

            _last_world[key] = land_world(spec, seed, cache, placed)
        else:
            _last_world[key] = build_world(spec, seed, cache)
    return _last_world[key]


@functools.lru_cache(maxsize=1)
def _keep_freed_memory() -> None:
    """Undo what Dask's nanny sets for its workers (MALLOC_TRIM_THRESHOLD_=65536): with it,
    glibc hands every large array back to the OS and page-faults it in again on the next
    scan, which slows every scan. Fixed thresholds keep freed arrays for reuse."""
    if not os.environ.get("MALLOC_TRIM_THRESHOLD_"):
        return
    try:
        import ctypes
        import ctypes.util

        libc = ctypes.CDLL(ctypes.util.find_library("c"))
        libc.mallopt(-3, 32 << 20)  # M_MMAP_THRESHOLD: arrays up to 32 MB from the reusable heap
        libc.mallopt(-1, 256 << 20)  # M_TRIM_THRESHOLD: give memory back only above 256 MB free
    except (OSError, AttributeError):
        pass  # not glibc: nothing to undo


def build_world(spec: DatasetSpec, seed: int, cache: DiskCache | None = None) -> WorldContext:
    """The world of `seed` ready to scan: read from the world cache when it holds it, else
    built (and stored there); its poses likewise (app/cache/worlds.py)."""
    from ..cache.worlds import prepared_world, world_inputs, world_poses

    t0 = time.perf_counter()
    world = prepared_world(world_inputs(seed, spec.detail, spec.vegetation, spec.biome), cache)
    backend = embree_backend(world.geometry, world.settler)
    poses, _ = world_poses(world, backend, spec.scans_per_world, spec.poses, cache)
    return WorldContext(
        seed=seed,
        backend=backend,
        poses=poses,
        instances=world.instances,
        z_range=world.z_range,
        open_ground=world.open_ground,
        build_seconds=time.perf_counter() - t0,
        ground=world.ground,
        cover=world.cover,
        from_cache=world.from_cache,
        sky=world.open_sky,
    )


# ---------------------------------------------------------------------------------------
# the task


def scan_batch(
    spec_json: dict,
    out: str,
    seed: int,
    indices: list[int],
    version: str,
    topic: str = "",
    label: str = "",
    cache: dict | None = None,
    placed: dict | None = None,
) -> dict:
    """Scan `indices` of world `seed` into `out`; return the manifest rows and worker facts.
    `cache`: where the worker keeps built worlds (app/cache/config.py; None: nowhere).
    `placed`: an endless world's poses, world_poses_task's result (None: the worker's own)."""
    _check_version(version)
    root = Path(out)
    if not root.is_dir():
        raise UserError(
            f"a Dask worker cannot see the output folder {out}: it must be on a file system "
            "every worker shares"
        )
    started = time.time()  # wall clock: the client lays every task on one timeline (timeline.py)
    spec = spec_from_json(spec_json)
    cached = _world_key(spec, seed) in _last_world
    disk = open_cache(cache)
    tiles = [TILE_WORK.copy()]  # the tiles built and read for the world (its poses), then its scans
    context = world_context(spec, seed, disk, None if placed is None else placed["poses"])
    tiles.append(TILE_WORK.copy())
    build = 0.0 if cached else context.build_seconds
    rows, failure = [], None
    before = CLOCK.reading()
    for index in indices:
        try:
            with CLOCK.scan():  # a dataset's scan: everything scan_one does (core/runtime/cast_clock.py)
                rows.append(scan_one(spec, context, root, index))
        except UserError as e:  # a full disk: the scans written before it are whole, so recorded
            if not rows:
                raise
            failure = str(e)
            break
        _tick(topic, label)
    source = "memory" if cached else "cache" if context.from_cache else "built"
    spent = CLOCK.reading() - before
    facts = _worker_facts(build) | world_facts(source, disk)
    facts |= {"scan_seconds": spent.scans, "cast_seconds": spent.cast, "task": [started, time.time()]}
    facts["tiles"] = tile_facts(*tiles, TILE_WORK.copy())
    return {"rows": rows, "worker": facts} | ({"failure": failure} if failure else {})


def world_poses_task(spec_json: dict, seed: int, version: str, cache: dict | None = None) -> dict:
    """The poses of the endless world `seed` (land.py land_poses), placed once for a run: the
    engine hands this task's result to every scan task of the world, which waits on it
    (engine.py), so two workers never place one world's poses side by side. Its facts are a
    scan task's, with no rows (the client adds them up the same way)."""
    from ..cache.worlds import pose_to_json
    from ..tile_memory import process_memory
    from .land import land_poses

    _check_version(version)
    started, t0 = time.time(), time.perf_counter()
    disk = open_cache(cache)
    before = TILE_WORK.copy()
    poses, cached = land_poses(spec_from_json(spec_json), seed, disk, process_memory())
    facts = _worker_facts(time.perf_counter() - t0) | world_facts("cache" if cached else "built", disk)
    facts |= {"task": [started, time.time()], "tiles": tile_facts(before, TILE_WORK.copy(), TILE_WORK.copy())}
    return {"rows": [], "worker": facts, "poses": [pose_to_json(p) for p in poses]}


def _check_version(version: str) -> None:
    if version != __version__:
        raise UserError(
            f"this Dask worker runs WildScan {__version__}, the client {version}: install the same on both"
        )


def tile_facts(before: TileWork, world: TileWork, after: TileWork) -> dict[str, float]:
    """A task's tiles (app/tiles.py TILE_WORK): built and read while its world was made (an
    endless world's poses: their placement stands on tiles) and while it scanned, with the
    seconds; summed over tasks by the client (RunReport.tiles), bench-dataset's floor."""
    out = {}
    for stage, work in (("world", world.since(before)), ("scans", after.since(world))):
        out |= {f"{stage}_built": work.built, f"{stage}_build_seconds": work.build_seconds}
        out |= {f"{stage}_read": work.read, f"{stage}_read_seconds": work.read_seconds}
    return out


def _tick(topic: str, label: str) -> None:
    """One scan done: a progress event for the client's bar (best effort, not the record)."""
    if not topic:
        return
    try:
        from distributed import get_worker

        get_worker().log_event(topic, label)
    except (ImportError, ValueError):
        pass  # not inside a Dask worker (tests call scan_batch directly)


def _worker_facts(build_seconds: float) -> dict:
    return {
        "pid": os.getpid(),
        "peak_rss_bytes": peak_resident_bytes(),  # its own, not its starter's (core/runtime/peak.py)
        "world_build_seconds": build_seconds,
        "bpy_imported": "bpy" in sys.modules,  # the Blender-free path: tests check it stays False
    }


@functools.lru_cache(maxsize=4)
def _splits(spec: DatasetSpec) -> dict[int, str]:
    return spec.splits()


@functools.lru_cache(maxsize=4)
def _config_hash(spec: DatasetSpec) -> str:
    return spec.config_hash()


def base_row(spec: DatasetSpec, seed: int, index: int) -> dict:
    return {
        "seed": seed,
        "sequence": spec.sequence_of(seed),
        "scan": index,
        "split": _splits(spec)[seed],
        "config_hash": _config_hash(spec),
        "wildscan_version": __version__,
    }


def _effects(weather: dict, sensor, cover=None, others=None):
    from ..scan import scan_effects

    return scan_effects(weather, sensor, cover, others)


def scan_one(spec: DatasetSpec, context: WorldContext, root: Path, index: int) -> dict:
    t0 = time.perf_counter()
    row = base_row(spec, context.seed, index)
    choice = context.poses[index]
    if isinstance(choice, NoPose):
        return dict(row, zone=choice.zone, status="failed", reason=choice.reason, files=[], seconds=0.0)
    row.update(zone=choice.zone, pose=choice.to_dict())
    sensor = draw_sensor(spec.sensor, context.seed, index)
    context = context.for_scan(choice, sensor)
    frame = spec.sensor.frame
    row["sensor"] = sensor_row(sensor, frame)
    weather, others = draw_weather(spec, context.seed, index), draw_effects(spec, context.seed, index)
    row.update({k: v for k, v in (("weather", weather), ("effects", others)) if v})
    try:
        result = run_scan(
            context.backend,
            choice.pose,
            sensor,
            frame,
            choice.z_start,
            None,
            _effects(weather, sensor, context.cover, others),
            incidence=spec.intensity == "physical",  # the physical intensity's cos θ, from the sweep
            world_seed=context.seed,  # the surfaces' reflectances, as the physical intensity's
        )
    except PoseRejected as e:
        return dict(row, status="failed", reason=str(e), files=[], seconds=time.perf_counter() - t0)
    world = world_points(result.cloud.xyz, result.placement, frame)  # for intensity and ground truth
    result = with_dataset_intensity(spec.intensity, context.seed, index, result, world)
    placement = result.placement
    row["placement"] = {
        "optical_centre": [float(v) for v in placement.optical_centre],
        "roll_deg": placement.roll_deg,
        "pitch_deg": placement.pitch_deg,
    }
    written = write_scan(root, encode_scan(spec, context, row, result, world))
    cloud = result.cloud
    row.update(
        status="ok",
        pose_matrix=[float(v) for v in pose_matrix(placement, frame)[:3, :4].ravel()],
        points=len(cloud),
        class_counts=_class_counts(cloud.label),
        range_histogram=np.bincount(
            np.minimum((cloud.range / RANGE_BIN).astype(np.int64), RANGE_BINS - 1), minlength=RANGE_BINS
        ).tolist(),
        files=written,
        **_echo_counts(cloud),
        **scan_intensity_facts(cloud),
        **_lost_returns(result.metadata),
    )
    if spec.layout == "endless":  # the card's share of points near the sensor (a paper row as before)
        from .land_card import NEAR_SENSOR_M

        row["near_points"] = int(np.count_nonzero(cloud.range < NEAR_SENSOR_M))
    row["seconds"] = time.perf_counter() - t0
    return row


def sensor_row(sensor, frame: str) -> dict:
    """The sensor values of one scan as the manifest records them, in SPEC.toml's names. A
    paper-model row says what it said before the realistic model existed; `noise` null is
    the realistic model's datasheet noise (its sigma depends on the range)."""
    row = {
        "rh": sensor.rh_deg,
        "min_range": sensor.min_range,
        "max_range": sensor.max_range,
        "noise": sensor.fixed_noise,
        "noise_seed": sensor.noise_seed,
        "frame": frame,
    }
    if sensor.mount_height != COLUMN_HEIGHT:  # a row at the paper's column says what it said
        row["mount_height"] = sensor.mount_height
    if sensor.realistic:
        row.update(
            model=sensor.model,
            divergence=sensor.divergence_mrad,
            echoes=sensor.echoes,
            echo_separation=sensor.echo_separation,
        )
        if sensor.device.optics.returns != ("multi",):
            row["returns"] = sensor.return_mode
    return row


def _echo_counts(cloud) -> dict:
    """A realistic scan's points by echo (1st, 2nd, 3rd) and its mixed pixels (dataset card)."""
    if "echo" not in cloud.extra:
        return {}
    by_echo = np.bincount(cloud.extra["echo"], minlength=4)[1:4]
    return {"echo_counts": by_echo.tolist(), "mixed_points": int(np.count_nonzero(cloud.extra["mixed"]))}


def _lost_returns(metadata: dict) -> dict:
    """A realistic scan's returns lost to the detection step (core/realism/lost_returns.py): the card's."""
    lost = metadata.get("echoes", {}).get("lost_returns")
    return {} if lost is None else {"lost_returns": lost}


def _class_counts(labels: np.ndarray) -> dict[str, int]:
    counts = np.bincount(labels, minlength=1)
    return {str(k): int(n) for k, n in enumerate(counts) if n}


def encode_scan(spec: DatasetSpec, context: WorldContext, row: dict, result, world=None) -> dict[str, bytes]:
    """Relative path -> bytes of every file of one scan: the bird's-eye grid, then each format's
    files from the format table (core/io/formats.py), in the spec's order. `world`: the cloud's
    points in the world frame, when the caller has them already."""
    from ...core.io.formats import WRITERS
    from ...core.io.writer import ScanOutput

    cloud, placement, frame = result.cloud, result.placement, row["sensor"]["frame"]
    labels = scheme(spec.label_scheme)
    if world is None:
        world = world_points(cloud.xyz, placement, frame)
    hag = height_above_ground(world, context.ground)
    paths = scan_paths(spec.formats, row["sequence"], context.file_numbers[row["scan"]])
    grid = bev_grid(
        context.top_classes,
        context.ground,
        placement,
        context.extent,
        context.z_range,
        context.traversability,
    )
    files = {paths["bev"]: npy_bytes(map_top_class(grid, labels.lookup()))}
    scan = ScanOutput(
        cloud,
        _metadata(row, result.metadata),
        labels,
        context.instances,
        hag,
        support=support_flags(cloud.label, hag),
        lost_cells=result.lost_cells,
    )
    row["class_heights"] = class_height_histogram(cloud.label, hag)
    for name in spec.formats:
        encoded = WRITERS[name].encode(scan, {kind: Path(path) for kind, path in paths.items()})
        files.update((paths[kind], data) for kind, data in encoded.items())
    return files


def _metadata(row: dict, metadata: dict) -> dict:
    """A dataset scan's metadata: the header keeps to short lines (readers with fixed line
    buffers): the four lasers' record stays out; the placement is summed up."""
    meta = {k: v for k, v in metadata.items() if k not in ("placement", "classes")}
    meta.update(
        seed=row["seed"],
        world=None,
        placement=row["placement"],
        dataset={
            "sequence": row["sequence"],
            "scan": row["scan"],
            "split": row["split"],
            "zone": row["zone"],
        },
    )
    return meta


def write_scan(root: Path, files: dict[str, bytes]) -> list[dict]:
    """Write one scan's files all together (temporary names, then renames); their records."""
    finals = [root / rel for rel in files]
    for folder in {p.parent for p in finals}:
        folder.mkdir(parents=True, exist_ok=True)
    # No fsync per file or folder (a flush to disk per scan would cost more than writing its
    # files): after a power cut the next run re-checks every file against the manifest's
    # SHA-256 and writes again any that did not survive.
    with atomic_outputs(*finals, durable=False) as temps:
        for tmp, data in zip(temps, files.values(), strict=True):
            tmp.write_bytes(data)
    return [
        {"path": rel, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
        for rel, data in files.items()
    ]
