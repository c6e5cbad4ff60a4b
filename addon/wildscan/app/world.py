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
    ZONES,
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
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    check_biome(biome)
    if fresh:
        from ..blender.scene_io import empty_scene

        empty_scene()

    from ..blender.builder import build_world
    from ..blender.replace import replacing_generated

    return replacing_generated(
        lambda: build_world(seed, detail, progress=progress, vegetation=vegetation, biome=biome)
    )


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
) -> SavedWorld:
    """Build the world of `seed` and save it as a .blend, with its JSON sidecar (zones,
    extents, features, up to `poses_per_zone` valid scan poses a zone) and optionally an
    aerial map: all of them or none."""
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    check_biome(biome)
    blend, png = check_world_outputs(out, map_path)
    sidecar = sidecar_path(blend)
    stage = progress or (lambda _stage, _seconds: None)

    t_start = time.perf_counter()
    plan = build_in_scene(seed, detail, progress, fresh, vegetation, biome)
    t0 = time.perf_counter()
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
            crosses = [Site(z, p["x"], p["y"], p["yaw"], p["kind"]) for z in ZONES for p in poses[z]]
            with writing_to(png):  # matplotlib's errors often name no file: say which one failed
                render_map(plan, str(temps[2]), poses=crosses)
            stage("aerial map", time.perf_counter() - t0)
        description = plan.describe(poses)
        description["blend"] = str(blend)
        description["map"] = str(png) if png else None
        with writing_to(sidecar):
            temps[1].write_text(json.dumps(description, indent=1) + "\n")
    return SavedWorld(plan, poses, blend, sidecar, png, time.perf_counter() - t_start)
