"""One labeled 3D scan from a pose: placement, sweep, ranges, labels, leveling. Numpy only.

The scene enters only through `backend.cast` (raycast/base.py; it returns core.hits.RayHits), so this module
runs the same with Blender's scene.ray_cast or a fast backend.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .. import __version__
from .classes import WATER_ID, class_table_dict, label_from_reflectivity, reflectivity_of
from .frames import check_frame, to_world
from .hits import RayHits
from .placement import Placement, Pose, place
from .pointcloud import PointCloud
from .sensor import SensorConfig, beam_directions, range_noise

# Rays are cast a little past max range so a true range just beyond it can
# still come back inside after noise; the limit applies to the measured range.
NOISE_MARGIN_SIGMAS = 6.0
PROGRESS_CHUNK = 64_800  # rays per progress report (60 2D scans)

Progress = Callable[[int, int], None]


@dataclass
class ScanResult:
    cloud: PointCloud
    placement: Placement
    metadata: dict
    untagged_objects: frozenset[str] = field(default=frozenset())
    beams: int = 0
    hits: int = 0


def cast_in_chunks(
    backend,
    origin: np.ndarray,
    dirs: np.ndarray,
    max_range: float,
    progress: Progress | None,
    normals: bool = False,
):
    """Cast all rays, reporting progress between chunks when asked (with each hit's surface
    normal when `normals`: the realistic model's)."""
    extra = {"normals": True} if normals else {}
    if progress is None:
        return backend.cast(origin, dirs, max_range, **extra)
    parts = []
    total = len(dirs)
    for start in range(0, total, PROGRESS_CHUNK):
        parts.append(backend.cast(origin, dirs[start : start + PROGRESS_CHUNK], max_range, **extra))
        progress(min(start + PROGRESS_CHUNK, total), total)
    return RayHits.joined(parts)


def points_in_frame(points_sensor: np.ndarray, placement: Placement, frame: str) -> np.ndarray:
    """A scan's points in its output frame: leveled by Eq. 2 itself (the paper's leveling),
    the world frame by the frame conversion every other user of frames shares."""
    if frame == "sensor":
        return points_sensor
    if frame == "leveled":
        from .leveling import level_points

        return level_points(points_sensor, placement.roll_rad, placement.pitch_rad)
    return to_world(points_sensor, "sensor", placement)


def run_scan(
    backend,
    pose: Pose,
    sensor: SensorConfig,
    frame: str = "leveled",
    z_start: float | None = None,
    progress: Progress | None = None,
) -> ScanResult:
    sensor.validate()
    check_frame(frame)
    if sensor.realistic:
        from .realistic import check_backend

        check_backend(backend)
    placement = place(backend, pose, z_start)
    beam_count = sensor.beam_count
    cast_range = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma
    if sensor.realistic:
        cloud, facts = _realistic_cloud(backend, placement, sensor, frame, cast_range, progress)
    else:
        cloud, facts = _paper_cloud(backend, placement, sensor, frame, cast_range, progress)
    untagged = facts.pop("untagged")
    metadata = {
        "wildscan_version": __version__,
        "pose": pose.to_dict(),
        "z_start": z_start,
        "frame": frame,
        "sensor": sensor.to_dict(),
        "backend": getattr(backend, "name", type(backend).__name__),
        "placement": placement.to_dict(),
        "beams": int(beam_count),
        **{k: v for k, v in facts.items() if k != "hits"},
        "points": int(len(cloud)),
        "untagged_objects_hit": sorted(untagged),
        "classes": class_table_dict(),
    }
    return ScanResult(
        cloud=cloud,
        placement=placement,
        metadata=metadata,
        untagged_objects=untagged,
        beams=beam_count,
        hits=facts["hits"],
    )


def _paper_cloud(
    backend, placement: Placement, sensor: SensorConfig, frame: str, cast_range: float, progress
):
    """The paper's scan: one thin ray a beam, its first hit, intensity = reflectivity."""
    dirs_sensor, ring, sweep = beam_directions(sensor.rh_deg)
    dirs_world = dirs_sensor @ placement.rotation.T
    hits = cast_in_chunks(backend, placement.optical_centre, dirs_world, cast_range, progress)

    measured = hits.distance + range_noise(sensor, len(dirs_sensor))
    keep = hits.hit & (measured >= sensor.min_range) & (measured <= sensor.max_range)
    intensity = reflectivity_of(np.where(keep, hits.class_id, 0))
    label = label_from_reflectivity(intensity)
    # A beam whose first hit is water returns nothing (the paper drops them).
    keep &= label != WATER_ID

    rho = measured[keep]
    points_sensor = dirs_sensor[keep] * rho[:, None]
    cloud = PointCloud(
        xyz=points_in_frame(points_sensor, placement, frame),
        intensity=intensity[keep].astype(np.float32),
        label=label[keep].astype(np.uint16),
        instance=np.maximum(hits.instance[keep], 0).astype(np.uint32),
        ring=ring[keep],
        sweep=sweep[keep],
        range=rho.astype(np.float32),
        frame=frame,
    )
    facts = {
        "returns": int(hits.hit.sum()),
        "water_returns_dropped": int((hits.class_id == WATER_ID).sum()),
        "hits": int(hits.hit.sum()),
        "untagged": hits.untagged_objects,
    }
    return cloud, facts


def _realistic_cloud(
    backend, placement: Placement, sensor: SensorConfig, frame: str, cast_range: float, progress
):
    """The realistic model's scan (core/realistic.py): a point per echo, with its echo fields."""
    from .realistic import realistic_points

    dirs_sensor, ring, sweep = beam_directions(sensor.rh_deg)
    untagged: set[str] = set()

    def cast(origins, dirs, max_range, normals):
        hits = cast_in_chunks(backend, origins, dirs, max_range, progress if normals else None, normals)
        untagged.update(hits.untagged_objects)
        return hits

    pts = realistic_points(cast, placement.optical_centre, placement.rotation, sensor, cast_range)
    points_sensor = dirs_sensor[pts.beam] * pts.range[:, None]
    cloud = PointCloud(
        xyz=points_in_frame(points_sensor, placement, frame),
        intensity=pts.intensity.astype(np.float32),
        label=pts.label.astype(np.uint16),
        instance=np.maximum(pts.instance, 0).astype(np.uint32),
        ring=ring[pts.beam],
        sweep=sweep[pts.beam],
        range=pts.range.astype(np.float32),
        frame=frame,
        extra={
            "echo": pts.echo,
            "echoes": pts.echoes,
            "label_purity": pts.purity.astype(np.float32),
            "mixed": pts.mixed.astype(np.uint8),
        },
    )
    beams_hit = int(len(np.unique(pts.beam)))
    facts = {
        "returns": int(len(pts.beam)),
        "hits": beams_hit,
        "echoes": pts.stats,
        "untagged": frozenset(untagged),
    }
    return cloud, facts
