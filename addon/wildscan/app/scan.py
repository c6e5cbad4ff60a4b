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
from .tiles import PLACEMENT_RADIUS_M, placement_caster

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
    backend: str = "embree",
    z_start: float | None = None,
):
    """(SceneGeometry, TileCounts): the endless world of `seed` as a scan from `pose` sees it,
    the tiles within the sensor's reach (crop_radius; `reach` when given: a dataset's scan also
    needs its bird's-eye square), each at the level the device resolves there (full detail with
    `lod` off), from memory, the world cache or built (app/tiles.py). With `lod` on, tiles
    beyond full detail (a far-reaching device) and the geometry for the scan alone (no
    `reach`), the triangles no beam of the scan can meet are left out (beam_reach), which
    changes none of its points; the scan's `backend` and `z_start` place it first, as the
    scan will."""
    from .tiles import TiledWorld, scan_levels, tiles_geometry

    world = TiledWorld(seed, biome, detail, vegetation)
    culled = reach is None and lod
    reach = crop_radius(sensor) if reach is None else reach
    if not lod:
        check_full_detail_reach(reach, sensor)
    levels = scan_levels(sensor, pose.x, pose.y, reach, lod, detail)
    if culled and any(levels.values()):
        return _reached_geometry(
            world, levels, pose, sensor, reach, cache, memory, progress, backend, z_start
        )
    return tiles_geometry(world, levels, cache, memory, (pose.x, pose.y), progress, radius=reach)


def _reached_geometry(world, levels, pose, sensor, reach, cache, memory, progress, backend, z_start):
    """endless_scan_geometry's LOD scan: the tiles round the pose first (the placement's),
    then each tile, nearest first, cut to what the scan's beams can meet as soon as it is
    made: only those triangles are held together (the tile memory keeps whole tiles, bounded
    in bytes), so a far-reaching device's scan holds a fraction of its tiles' triangles."""
    import time

    from .tile_memory import TileCounts
    from .tiles import ELEMENT_OVERHANG_M, cut, endless, join, tile_part

    t0, counts = time.perf_counter(), TileCounts()
    centre = (pose.x, pose.y)
    order = sorted(levels, key=lambda t: (endless().tile_distance(*t, pose.x, pose.y), t))
    made = {}
    for t in order:  # the placement's tiles: every element that can stand within its reach
        if endless().tile_distance(*t, pose.x, pose.y) <= PLACEMENT_RADIUS_M + ELEMENT_OVERHANG_M:
            made[t] = tile_part(world, t, levels[t], cache, memory, counts)
    keep = beam_reach([made[t] for t in sorted(made)], pose, sensor, backend, z_start)
    kept = {}
    for k, t in enumerate(order):
        part = made.pop(t, None) or tile_part(world, t, levels[t], cache, memory, counts)
        kept[t] = cut(part, centre, reach, keep)
        if progress is not None:
            progress(k + 1, len(order))
    geometry = join([kept[t] for t in sorted(kept)], centre)
    counts.seconds = time.perf_counter() - t0
    return geometry, counts


# m: the farthest a `--lod off` scan builds every tile at full detail. A 120 m device's scan
# reaches ~123 m: ~31 tiles, 4-6 M triangles, 2-3 GB while it is made; a 245 m device's would be
# ~100 tiles (15 GB resident measured on a 2-core machine before it was killed)
FULL_DETAIL_REACH_M = 130.0


def check_full_detail_reach(reach: float, sensor: SensorConfig) -> None:
    """A UserError when a `--lod off` scan would build full-detail tiles farther than
    FULL_DETAIL_REACH_M."""
    if reach > FULL_DETAIL_REACH_M:
        limit = FULL_DETAIL_REACH_M - (reach - sensor.max_range)
        raise UserError(
            f"off builds every tile within the scan's reach at full detail: {reach:.0f} m for "
            f"max_range {sensor.max_range:g} m, more than the {FULL_DETAIL_REACH_M:g} m it may (the tiles "
            f"would take tens of GB); use --lod on, or --max-range {limit:.0f} or less",
            setting="lod",
            allowed=("on",),
        )


def beam_reach(parts, pose: Pose, sensor: SensorConfig, backend: str, z_start: float | None):
    """`keep(vertices, faces)` for app/tiles.py join: the triangles some beam of the scan may meet
    (raycast/beam_reach.py) or that lie within PLACEMENT_RADIUS_M of the pose. The beams'
    directions are the placement's (placed on the tiles' triangles round the pose, as the scan
    places itself); None when the pose cannot be placed (the scan then says why)."""
    from ..core.errors import PoseRejected
    from ..core.placement import place
    from ..core.sensors.beams import rotated_beam_directions
    from ..raycast.beam_reach import MARGIN_RAD, BeamGrid

    centre = (pose.x, pose.y)
    try:
        placement = place(placement_caster(parts, centre, backend), pose, z_start, sensor.mount_height)
    except PoseRejected:
        return None
    # a realistic beam's sub-rays leave its axis by less than its full divergence (core/realism/footprint.py)
    margin = MARGIN_RAD + (1e-3 * sensor.divergence_mrad if sensor.realistic else 0.0)
    grid = BeamGrid(rotated_beam_directions(placement.rotation, sensor.rh_deg, sensor.device), margin)
    origin = placement.optical_centre

    def keep(vertices, faces):
        return grid.reachable(vertices, faces, origin, (centre, PLACEMENT_RADIUS_M))

    return keep
