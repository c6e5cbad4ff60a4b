"""Scene geometry as a file: extract a world once, scan it anywhere without Blender.

`extract` turns a world into the numpy triangles every fast backend casts against
(raycast/geometry.py SceneGeometry) and saves them (raycast/scene_file.py): a seed's
world through the Blender-free path (raycast/from_plan.py, no bpy), a .blend file or
the scene Blender has open through extraction (raycast/extract.py, bpy). `scan
--geometry` loads such a file and scans it with embree or bvh; the points equal a scan
of the world it came from, byte for byte.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..core.errors import UserError
from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION

# Backends that cast against SceneGeometry; scene.ray_cast needs the Blender scene itself.
GEOMETRY_BACKENDS = ("auto", "embree", "open3d", "bvh")


def world_geometry_of(
    world: str | None = None,
    seed: int | None = None,
    detail: str = "default",
    vegetation: str = DEFAULT_VEGETATION,
    quiet: bool = False,
    biome: str = DEFAULT_BIOME,
):
    """(SceneGeometry, metadata) of a world: the world of `seed` at `detail` with
    `vegetation` and `biome` planned without Blender, the .blend file `world` (`quiet`: without
    Blender's "Read blend" line), or (neither) the scene Blender has open."""
    if seed is not None:
        from ..raycast.from_plan import world_geometry

        metadata = {"seed": seed, "detail": detail, "vegetation": vegetation, "world": None}
        if biome != DEFAULT_BIOME:  # the default's metadata keeps its keys
            metadata["biome"] = biome
        return world_geometry(seed, detail, vegetation, biome), metadata
    from ..blender.scene_io import open_world, scene_provenance
    from ..raycast.extract import extract_scene

    if world is not None:
        open_world(world, quiet=quiet)
    scene_seed, blend = scene_provenance()
    return extract_scene(), {"seed": scene_seed, "detail": None, "world": blend}


def region_geometry_of(
    seed: int,
    layout: str,
    region,
    detail: str = "default",
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
    cache=None,
    memory=None,
    progress=None,
):
    """(SceneGeometry, metadata, tile counts or None) of a region (core/world/region.py Region) of
    the world of `seed`: on the endless layout its tiles at full detail (through the world
    cache, app/tiles.py), every triangle whose xy box meets the region; on the paper layout
    the island's, the same way (the default region is the whole island, as before)."""
    from ..core.world.region import DEFAULT_REGION
    from .tiles import TiledWorld, crop_to_region, region_levels, tiles_geometry

    if layout == "paper":
        geometry, metadata = world_geometry_of(None, seed, detail, vegetation, True, biome)
        if region != DEFAULT_REGION:
            geometry = crop_to_region(geometry, region)
            metadata["region"] = region.to_dict()
        return geometry, metadata, None
    world = TiledWorld(seed, biome, detail, vegetation)
    levels = region_levels(region)
    geometry, counts = tiles_geometry(world, levels, cache, memory, progress=progress, region=region)
    metadata = {"seed": seed, "layout": "endless", "detail": detail, "vegetation": vegetation}
    metadata.update(biome=biome, region=region.to_dict(), world=None)
    return geometry, metadata, counts


def extract(
    out: str | os.PathLike,
    world: str | None = None,
    seed: int | None = None,
    detail: str = "default",
    vegetation: str = DEFAULT_VEGETATION,
    quiet: bool = False,
    biome: str = DEFAULT_BIOME,
    layout: str = "paper",
    region=None,
    cache=None,
    progress=None,
):
    """Save the geometry of a world (see world_geometry_of; with `seed`, the `region` of its
    `layout`: region_geometry_of) to `out` (.npz); returns (path, geometry, metadata, tile
    counts or None). The output path is checked before any work."""
    from ..core.io.files import check_output_path
    from ..core.world.region import DEFAULT_REGION
    from ..raycast.scene_file import SUFFIX, save_geometry

    check_output_path(out, SUFFIX)
    if seed is not None and (layout != "paper" or (region is not None and region != DEFAULT_REGION)):
        region = DEFAULT_REGION if region is None else region
        geometry, metadata, counts = region_geometry_of(
            seed, layout, region, detail, vegetation, biome, cache, progress=progress
        )
    else:
        (geometry, metadata), counts = world_geometry_of(world, seed, detail, vegetation, quiet, biome), None
    return save_geometry(geometry, out, metadata), geometry, metadata, counts


def load_scan_geometry(path: str | os.PathLike, backend: str):
    """(SceneGeometry, metadata) of a geometry file to scan with `backend`; UserError when
    the file cannot be read or the backend needs a Blender scene."""
    from ..raycast.scene_file import load_geometry_file

    if backend not in GEOMETRY_BACKENDS:
        raise UserError(
            f"{backend} needs a Blender scene; a geometry file is scanned with "
            f"{', '.join(GEOMETRY_BACKENDS)}",
            setting="backend",
            allowed=GEOMETRY_BACKENDS,
        )
    geometry, header = load_geometry_file(path)
    metadata = dict(header.get("metadata") or {})
    metadata["geometry"] = str(Path(path).expanduser().resolve())
    return geometry, metadata
