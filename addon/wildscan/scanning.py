"""Scan the current Blender scene: the one function the CLI, the Blender scripts
and the add-on's Scan operator all call, so they give the same points."""
from __future__ import annotations

from typing import Callable

from .core.placement import Pose
from .core.scan import Progress, ScanResult, run_scan
from .core.sensor import SensorConfig

# Crop margin around the pose: the optical centre sits up to a column height
# off the pose's xy on tilted ground, and noise lets ranges run a little long.
CROP_MARGIN = 2.0  # m


def make_scene_backend(
    name: str, pose: Pose, sensor: SensorConfig, notify: Callable[[str], None] = print, geometry=None
):
    """A ray backend over the current scene, cropped to what a scan from `pose` can reach.

    Pass `geometry` (raycast.extract.extract_scene()) to scan many poses of one
    world from a single extraction.
    """
    from .raycast.select import make_backend

    return make_backend(
        name, center=(pose.x, pose.y), radius=sensor.max_range + CROP_MARGIN, notify=notify, geometry=geometry
    )


def scan_current_scene(
    pose: Pose,
    sensor: SensorConfig,
    frame: str = "leveled",
    z_start: float | None = None,
    backend: str = "auto",
    progress: Progress | None = None,
    notify: Callable[[str], None] = print,
    geometry=None,
) -> ScanResult:
    sensor.validate()
    pose.validate()
    backend_ = make_scene_backend(backend, pose, sensor, notify, geometry)
    return run_scan(backend_, pose, sensor, frame, z_start, progress)
