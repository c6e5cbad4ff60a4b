"""Scan the current Blender scene: the one function the CLI, the Blender scripts
and the add-on's Scan operator all call, so they give the same points."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from ..core.placement import COLUMN_HEIGHT, Pose, check_z_start
from ..core.scan import NOISE_MARGIN_SIGMAS, Progress, ScanResult, run_scan
from ..core.sensor import SensorConfig

# Crop margin around the pose beyond max range: the optical centre sits up to a
# column height off the pose's xy on tilted ground, plus a little slack.
CROP_MARGIN = 1.0  # m


def make_scene_backend(
    name: str, pose: Pose, sensor: SensorConfig, notify: Callable[[str], None] = print, geometry=None
):
    """A ray backend over the current scene, cropped to what a scan from `pose` can reach.

    Pass `geometry` (raycast.extract.extract_scene()) to scan many poses of one
    world from a single extraction.
    """
    from ..raycast.select import make_backend

    return make_backend(
        name, center=(pose.x, pose.y), radius=crop_radius(sensor), notify=notify, geometry=geometry
    )


def crop_radius(sensor: SensorConfig) -> float:
    """How far from the pose (in xy) a scan can reach: rays are cast past max range by
    the noise margin (core.scan), from an optical centre up to a column height off the pose."""
    return sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma + COLUMN_HEIGHT + CROP_MARGIN


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


def check_scan(pose: Pose, sensor: SensorConfig, z_start: float | None, out: str | os.PathLike) -> Path:
    """Everything a scan request could get wrong, checked before a world is opened or built:
    the sensor settings, the pose, the start height and the output file. The PLY path."""
    from ..core.io.ply import check_output_path

    sensor.validate()
    pose.validate()
    check_z_start(z_start)
    return check_output_path(out)


def open_scan_world(
    world: str | None = None,
    seed: int | None = None,
    progress=None,
    vegetation: str = "porous",
    quiet: bool = False,
) -> None:
    """The scene a scan sees: the .blend file `world`, or the world of `seed` built in an
    empty scene (with `vegetation`); with neither, the scene already open (a Blender started
    with a file). `quiet`: without Blender's "Read blend" line."""
    if world is not None:
        from ..blender.scene_io import open_world

        open_world(world, quiet=quiet)
    elif seed is not None:
        from .world import build_in_scene

        build_in_scene(seed, progress=progress, fresh=True, vegetation=vegetation)


def write_scan(
    out: str | os.PathLike,
    result: ScanResult,
    seed: int | None,
    world: str | None,
    ascii: bool = False,
    **extra,
) -> tuple[Path, Path]:
    """The scan's PLY and JSON sidecar, its metadata saying which world it saw (the seed it
    was built from, the .blend it was read from) plus `extra` (the demo's zone)."""
    from ..core.io.ply import write_scan_files

    metadata = dict(result.metadata, seed=seed, world=world, **extra)
    return write_scan_files(out, result.cloud, metadata, ascii=ascii)
