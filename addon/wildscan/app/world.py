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

from ..blender.scene_io import check_blender_path_length, quiet_stdout
from ..core.errors import UserError
from ..core.io.files import atomic_outputs, check_output_path, remove_quietly, temp_path, writing_to
from ..core.io.ply import sidecar_path
from ..core.signals import deferred
from ..core.world import DEFAULT_VEGETATION, ZONES, WorldPlan, check_seed, check_vegetation, detail_level
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
) -> WorldPlan:
    """Build the world of `seed` in the current scene, replacing only what WildScan built
    before (the user's own objects stay); if the build fails, the previous world is left
    exactly as it was. `fresh` starts from an empty factory scene (the command line)."""
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    if fresh:
        from ..blender.scene_io import empty_scene

        empty_scene()

    def build() -> WorldPlan:
        from ..blender.builder import build_world

        return build_world(seed, detail, progress=progress, vegetation=vegetation)

    return replacing_generated(build)


def replacing_generated(build: Callable[[], WorldPlan]) -> WorldPlan:
    """Run `build()` (which builds a world into the WildScan collection) so that it
    replaces the world WildScan built before, and a failure leaves that world exactly
    as it was.

    The previous world is found by what it is, not by its collection's name (a user
    may rename it): its root collection's marker (blender/mesh.py world_root) and every
    generated, class-tagged object in the scene, wherever the user moved it. It is set
    aside while the new one is built: its generated collections, objects and data get
    temporary names, so the new world gets the same names a first build would. On
    success the user's own objects and collections in the old root move to the new one
    and the generated rest is removed; on failure the partial new world is removed and
    the old one gets its names back.
    """
    import bpy

    from ..blender import WORLD_COLLECTION as ROOT
    from ..blender.mesh import (
        GENERATED,
        remove_generated,
        remove_objects_and_their_meshes,
        world_element_objects,
        world_root,
    )

    old = world_root()
    strays = world_element_objects()
    if old is None and not strays:
        return build()
    renamed, objects = _set_aside(old, strays, GENERATED)
    try:
        result = build()
    except BaseException:
        remove_generated(ROOT)
        for block, name in renamed:
            block.name = name
        raise
    new = bpy.data.collections.get(ROOT)
    if old is not None and new is not None and new != old:
        _adopt_user_content(old, new, GENERATED)
    remove_objects_and_their_meshes(objects)
    if old is not None:
        remove_generated(old.name)
    return result


def _set_aside(root, strays: set, generated: str) -> tuple[list, set]:
    """Give the generated collections under `root` (None: none), the generated objects in
    them and the `strays` and those objects' generated data temporary names; returns
    ((datablock, original name) pairs, the objects)."""
    collections = [] if root is None else [root, *(c for c in root.children_recursive if c.get(generated))]
    objects = {o for c in collections for o in c.objects if o.get(generated)} | set(strays)
    data = {o.data for o in objects if o.data is not None and o.data.get(generated)}
    renamed = []
    for i, block in enumerate([*collections, *objects, *data]):
        renamed.append((block, block.name))
        block.name = f".wildscan-replaced-{i}"
    return renamed, objects


def _parents_of(coll) -> list:
    import bpy

    parents = [c for c in bpy.data.collections if coll.name in c.children]
    parents += [s.collection for s in bpy.data.scenes if coll.name in s.collection.children]
    return parents


def _adopt_user_content(old, new, generated: str) -> None:
    """Give `new` the place and the user content `old` had."""
    for obj in [o for o in old.objects if not o.get(generated)]:
        if obj.name not in new.objects:
            new.objects.link(obj)
        old.objects.unlink(obj)
    for child in [c for c in old.children if not c.get(generated)]:
        if child.name not in new.children:
            new.children.link(child)
        old.children.unlink(child)
    old_parents = _parents_of(old)
    if old_parents:
        for parent in old_parents:
            if new.name not in parent.children:
                parent.children.link(new)
        for parent in _parents_of(new):
            if parent not in old_parents:
                parent.children.unlink(new)


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
) -> SavedWorld:
    """Build the world of `seed` and save it as a .blend, with its JSON sidecar (zones,
    extents, features, up to `poses_per_zone` valid scan poses a zone) and optionally an
    aerial map: all of them or none."""
    check_seed(seed)
    detail_level(detail)
    check_vegetation(vegetation)
    blend, png = check_world_outputs(out, map_path)
    sidecar = sidecar_path(blend)
    stage = progress or (lambda _stage, _seconds: None)

    t_start = time.perf_counter()
    plan = build_in_scene(seed, detail, progress, fresh, vegetation)
    t0 = time.perf_counter()
    poses = valid_poses(plan, plan_backend(plan), poses_per_zone)
    stage("valid poses", time.perf_counter() - t0)

    finals = (blend, sidecar, png) if png is not None else (blend, sidecar)
    with atomic_outputs(*finals) as temps:
        t0 = time.perf_counter()
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


def save_blend(tmp: Path, final: Path) -> None:
    """Save the current file as a copy at `tmp`; Blender reports failure as RuntimeError.

    Blender writes `tmp@` and renames it to `tmp`: that file goes too when the save fails
    or a signal stops the run, and Blender's message is reworded to name `final`."""
    import bpy

    try:
        # quiet: Blender's own "Info: Saved copy as ..." line; deferred: Blender swallows a
        # KeyboardInterrupt raised in its save handlers
        with quiet_stdout(), deferred():
            bpy.ops.wm.save_as_mainfile(filepath=str(tmp), check_existing=False, copy=True, compress=True)
    except RuntimeError as e:
        raise UserError(f"cannot write {final}: {blender_save_reason(e, tmp)}") from None
    finally:
        remove_quietly([Path(f"{tmp}@")])


def blender_save_reason(error: RuntimeError, tmp: Path) -> str:
    """Why Blender could not save, without its temporary names or its "Error:" prefix."""
    lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
    reason = (lines[0] if lines else "").removeprefix("Error:").strip()
    if str(tmp) in reason:  # "Cannot open file TMP@ for writing: REASON": keep the reason
        reason = reason.rsplit(":", 1)[-1].strip() if ":" in reason.split(str(tmp))[-1] else ""
    return reason or "Blender could not save it"
