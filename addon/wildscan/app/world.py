"""Building a world in Blender: the one rebuild that `wildscan world`, `wildscan scan --seed`,
the demo and the add-on's Generate button share, and saving a world with its sidecar and map.

Every user mistake raises UserError before anything is built or written; files are
written to hidden temporary names beside their targets and renamed at the end.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..blender.scene_io import check_blender_path_length
from ..core.io.files import atomic_outputs, check_output_path, temp_path, writing_to
from ..core.io.ply import sidecar_path
from ..core.world import (
    DEFAULT_BIOME,
    DEFAULT_VEGETATION,
    WorldPlan,
    check_biome,
    check_seed,
    check_vegetation,
    detail_level,
)
from .poses import DEFAULT_POSES_PER_ZONE, plan_backend, valid_poses

StageProgress = Callable[[str, float], None]  # (stage, seconds) after each stage


# ---------------------------------------------------------------------------------------
# building in the current scene


def build_in_scene(
    seed: int,
    detail: str = "default",
    progress: StageProgress | None = None,
    fresh: bool = False,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
) -> WorldPlan:
    """Build the world of `seed` in the current scene, replacing only what WildScan built
    before (the user's own objects stay); if the build fails, the previous world is left
    exactly as it was. `fresh` starts from an empty factory scene (the command line)."""
    _ready_to_build(seed, detail, vegetation, biome, fresh)
    from ..blender.builder import build_world
    from ..blender.replace import replacing_generated

    def build() -> WorldPlan:
        plan = build_world(seed, detail, progress=progress, vegetation=vegetation, biome=biome)
        record_region(None)  # the whole island: no region of an endless world (one built before)
        return plan

    return replacing_generated(build)


def _ready_to_build(seed: int, detail: str, vegetation: str, biome: str, fresh: bool) -> None:
    """Check a build's inputs (UserError before anything changes); `fresh`: an empty scene."""
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    check_biome(biome)
    if fresh:
        from ..blender.scene_io import empty_scene

        empty_scene()


def build_region_in_scene(
    seed: int,
    region,
    detail: str = "default",
    progress: StageProgress | None = None,
    fresh: bool = False,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
) -> WorldPlan:
    """Build `region` (core/world/region.py Region) of the endless world of `seed` in the current
    scene, every tile it touches at full detail, replacing only what WildScan built before
    (as build_in_scene). The built region is recorded on the world's root collection, so a
    scan in Blender can tell when its sensor reaches past it (ui/)."""
    _ready_to_build(seed, detail, vegetation, biome, fresh)
    from ..blender.builder import realise
    from ..blender.replace import replacing_generated
    from .tiles import endless, region_levels

    def build() -> WorldPlan:
        t0 = time.perf_counter()
        levels = region_levels(region, 0.0)  # whole tiles, each with its elements
        plan = endless().plan_region(seed, biome, detail, vegetation, sorted(levels), levels)
        if progress is not None:
            progress(f"plan {len(levels)} tiles", time.perf_counter() - t0)
        realise(plan, progress=progress)
        record_region(region)
        return plan

    return replacing_generated(build)


def record_region(region) -> None:
    """Keep the built region on the world's root collection (the panel and scans read it);
    None: the paper's island, no region."""
    import bpy

    from ..blender.builder import WORLD_COLLECTION

    root = bpy.data.collections.get(WORLD_COLLECTION)
    if root is None:
        return
    root["wildscan_layout"] = "endless" if region is not None else "paper"
    if region is not None:
        root["wildscan_region"] = [float(v) for v in region]
    elif "wildscan_region" in root:
        del root["wildscan_region"]


# ---------------------------------------------------------------------------------------
# saving: `wildscan world`


@dataclass
class SavedWorld:
    """A world built and saved: its plan, the valid poses its sidecar lists, the files."""

    plan: WorldPlan
    poses: dict[str, list[dict]]
    blend: Path
    sidecar: Path
    map: Path | None
    seconds: float  # building and saving, from the empty scene to the files renamed in place


def check_world_outputs(
    out: str | os.PathLike, map_path: str | os.PathLike | None
) -> tuple[Path, Path | None]:
    """The .blend path (and the map's), or UserError, before anything is built."""
    # A scan's sidecar names its PLY file; a world beside it must not replace it.
    blend = check_output_path(out, ".blend", "out", companions=(".json",), foreign_sidecar_key="ply_file")
    check_blender_path_length(str(blend), "out", written_as=f"{temp_path(blend)}@")  # save_blend's name
    if map_path is None:
        return blend, None
    png = check_output_path(map_path, ".png", "map")
    from ..viz import require_matplotlib

    require_matplotlib("map")
    return blend, png


def make_world(
    seed: int,
    detail: str,
    out: str | os.PathLike,
    map_path: str | os.PathLike | None = None,
    poses_per_zone: int = DEFAULT_POSES_PER_ZONE,
    progress: StageProgress | None = None,
    fresh: bool = True,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
    layout: str = "paper",
    region=None,
    cache=None,
) -> SavedWorld:
    """Build the world of `seed` and save it as a .blend, with its JSON sidecar (zones,
    extents, features, up to `poses_per_zone` valid scan poses a zone) and optionally an
    aerial map: all of them or none. `layout` endless: the `region` of the endless world
    (default the 150 m square around the origin), its sidecar listing `poses_per_zone`
    poses per land cover found there; `cache` keeps its tiles' triangles for the poses."""
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    check_biome(biome)
    blend, png = check_world_outputs(out, map_path)
    sidecar = sidecar_path(blend)
    stage = progress or (lambda _stage, _seconds: None)

    t_start = time.perf_counter()
    if layout == "endless":
        from ..core.world.region import DEFAULT_REGION

        region = DEFAULT_REGION if region is None else region
        plan = build_region_in_scene(seed, region, detail, progress, fresh, vegetation, biome)
    else:
        plan = build_in_scene(seed, detail, progress, fresh, vegetation, biome)
    t0 = time.perf_counter()
    if layout == "endless":
        poses = _endless_poses(plan, region, poses_per_zone, cache)
    else:
        poses = valid_poses(plan, plan_backend(plan), poses_per_zone)
    stage("valid poses", time.perf_counter() - t0)

    finals = (blend, sidecar, png) if png is not None else (blend, sidecar)
    with atomic_outputs(*finals) as temps:
        t0 = time.perf_counter()
        from ..blender.scene_io import save_blend

        save_blend(temps[0], blend)
        stage("save .blend", time.perf_counter() - t0)
        if png is not None:
            from ..core.world import Site
            from ..viz.aerial_map import render_map

            t0 = time.perf_counter()
            crosses = [Site(z, p["x"], p["y"], p["yaw"], p.get("kind", z)) for z in poses for p in poses[z]]
            extent = None if layout != "endless" else region.extent()
            with writing_to(png):  # matplotlib's errors often name no file: say which one failed
                render_map(plan, str(temps[2]), poses=crosses, extent=extent)
            stage("aerial map", time.perf_counter() - t0)
        description = (
            plan.describe(poses) if layout != "endless" else _endless_description(plan, region, poses)
        )
        description["blend"] = str(blend)
        description["map"] = str(png) if png else None
        with writing_to(sidecar):
            temps[1].write_text(json.dumps(description, indent=1) + "\n")
    return SavedWorld(plan, poses, blend, sidecar, png, time.perf_counter() - t_start)


def _endless_poses(plan: WorldPlan, region, per_cover: int, cache) -> dict[str, list[dict]]:
    """Up to `per_cover` valid poses of each land cover in the region (the sidecar's)."""
    from .poses import TileBackends, endless_poses
    from .tile_memory import process_memory
    from .tiles import TiledWorld, endless

    world = TiledWorld(plan.seed, plan.biome, plan.detail.name, plan.vegetation)
    backends = TileBackends(world, cache, process_memory())
    return {
        cover: endless_poses(world, region, per_cover, (cover,), backends=backends)
        for cover in endless().LAND_COVERS
    }


def _endless_description(plan: WorldPlan, region, poses: dict[str, list[dict]]) -> dict:
    """The sidecar of a region of the endless world: what it is, where, and its poses."""
    return {
        "seed": plan.seed,
        "layout": "endless",
        "region": region.to_dict(),
        "detail": plan.detail.name,
        "vegetation": plan.vegetation,
        "biome": plan.biome,
        "counts": plan.counts(),
        "poses": poses,
    }
