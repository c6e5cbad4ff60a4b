"""Scan the current Blender scene: the one function the CLI, the Blender scripts
and the add-on's Scan operator all call, so they give the same points."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from ..core.backend import RayBackend
from ..core.errors import UserError
from ..core.placement import Pose, check_z_start
from ..core.scan import NOISE_MARGIN_SIGMAS, Progress, ScanResult, run_scan
from ..core.sensors import SensorConfig
from ..core.world.biomes import DEFAULT_BIOME

# Crop margin around the pose beyond max range: the optical centre sits up to a
# column height off the pose's xy on tilted ground, plus a little slack.
CROP_MARGIN = 1.0  # m


def make_scene_backend(
    name: str, pose: Pose, sensor: SensorConfig, notify: Callable[[str], None] = print, geometry=None
) -> RayBackend:
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
    return sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma + sensor.mount_height + CROP_MARGIN


def scan_current_scene(
    pose: Pose,
    sensor: SensorConfig,
    frame: str = "leveled",
    z_start: float | None = None,
    backend: str = "auto",
    progress: Progress | None = None,
    notify: Callable[[str], None] = print,
    geometry=None,
    weather: dict[str, float] | None = None,
    effects: dict[str, float] | None = None,
    world_seed: int = 0,
) -> ScanResult:
    """`weather`: key -> value (core/effects/weather.py KEYS); None or all 0: clear air;
    `effects`: the other effects of the effects table (core/effects/table.py), name -> value.
    `world_seed`: the world's seed (its surfaces' reflectances: core/realism/lost_returns.py)."""
    sensor.validate()
    pose.validate()
    effects = scan_effects(weather, sensor, scene_cover(geometry), effects)
    backend_ = make_scene_backend(backend, pose, sensor, notify, geometry)
    return run_scan(backend_, pose, sensor, frame, z_start, progress, effects, world_seed=world_seed)


def scan_effects(weather: dict[str, float] | None, sensor: SensorConfig, cover=None, others=None):
    """The effects of a scan in `weather` with `sensor`: its device's numbers, its noise seed
    (the same seed, the same particles); the world's ground cover first (a CoverGrid: the
    sward a beam stops in, core/effects/cover.py); then the effects table's (weather and
    `others`: name -> value, core/effects/table.py) in its order; clear air when none is on."""
    from ..core.effects import CLEAR_AIR, Effects
    from ..core.effects.table import user_effects

    items = () if cover is None else (_ground_cover(cover, sensor.noise_seed),)
    items += user_effects({"weather": weather, **(others or {})}, sensor)
    return Effects(items) if items else CLEAR_AIR


def _ground_cover(cover, noise_seed: int):
    from ..core.effects.cover import GroundCover

    return GroundCover(cover, noise_seed)


def scene_cover(geometry=None):
    """The ground cover a scan sees: the geometry's (a plan's, a geometry file's), or with no
    geometry given the cover the open Blender scene's world carries (None: bare ground)."""
    if geometry is not None:
        return geometry.cover
    try:
        from ..blender.cover import scene_cover as from_scene
    except ImportError:  # no bpy: nothing open to read
        return None
    return from_scene()


def check_scan(
    pose: Pose,
    sensor: SensorConfig,
    z_start: float | None,
    out: str | os.PathLike,
    fmt: str = "ply",
    ascii: bool = False,
) -> Path:
    """Everything a scan request could get wrong, checked before a world is opened or built:
    the sensor settings, the pose, the start height, the format and the output file (core/io/
    formats.py: --out names the format's first file). The resolved --out."""
    from ..core.io import formats

    sensor.validate()
    pose.validate()
    check_z_start(z_start)
    w = formats.writer(fmt)
    formats.check_ascii(w, ascii)
    return formats.check_scan_output(w, out)


def check_range_image(path: str | os.PathLike | None, out: Path, fmt: str = "ply") -> Path | None:
    """The resolved --range-image (an .npz beside none of the scan's own files), or None."""
    if path is None:
        return None
    from ..core.io import formats
    from ..core.io.files import check_output_path

    image = check_output_path(path, ".npz", "range_image")
    if image in formats.scan_paths(formats.writer(fmt), out).values():
        raise UserError(f"{image} is a file of the scan itself: name another", setting="range_image")
    return image


def open_scan_world(
    world: str | None = None,
    seed: int | None = None,
    progress=None,
    vegetation: str = "porous",
    quiet: bool = False,
    biome: str = DEFAULT_BIOME,
) -> None:
    """The scene a scan sees: the .blend file `world`, or the world of `seed` built in an
    empty scene (with `vegetation`); with neither, the scene already open (a Blender started
    with a file). `quiet`: without Blender's "Read blend" line."""
    if world is not None:
        from ..blender.scene_io import open_world

        open_world(world, quiet=quiet)
    elif seed is not None:
        from .world import build_in_scene

        build_in_scene(seed, progress=progress, fresh=True, vegetation=vegetation, biome=biome)


def write_scan(
    out: str | os.PathLike,
    result: ScanResult,
    seed: int | None,
    world: str | None,
    ascii: bool = False,
    fmt: str = "ply",
    range_image: Path | None = None,
    **extra,
) -> list[Path]:
    """The scan's files in format `fmt` (PLY: the PLY and its JSON sidecar), --out first, its
    metadata saying which world it saw (the seed it was built from, the .blend it was read
    from) plus `extra` (the demo's zone); its range image to `range_image` when given."""
    from ..core.io import formats

    metadata = dict(result.metadata, seed=seed, world=world, **extra)
    w = formats.writer(fmt)
    scan = formats.single_scan(w, result.cloud, metadata, ascii, result.lost_cells)
    return formats.write_scan(w, scan, out, range_image)


def endless_scan_geometry(
    seed: int,
    pose: Pose,
    sensor: SensorConfig,
    lod: bool = True,
    biome: str = DEFAULT_BIOME,
    vegetation: str = "porous",
    detail: str = "default",
    cache=None,
    memory=None,
    progress=None,
    reach: float | None = None,
):
    """(SceneGeometry, TileCounts): the endless world of `seed` as a scan from `pose` sees it,
    the tiles within the sensor's reach (crop_radius; `reach` when given: a dataset's scan also
    needs its bird's-eye square), each at the level the device resolves there (full detail with
    `lod` off), from memory, the world cache or built (app/tiles.py)."""
    from .tiles import TiledWorld, scan_levels, tiles_geometry

    world = TiledWorld(seed, biome, detail, vegetation)
    reach = crop_radius(sensor) if reach is None else reach
    levels = scan_levels(sensor, pose.x, pose.y, reach, lod, detail)
    return tiles_geometry(world, levels, cache, memory, (pose.x, pose.y), progress, radius=reach)
