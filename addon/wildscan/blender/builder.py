"""Realise a WorldPlan as tagged Blender objects (bpy; thin).

Layout in the outliner: "WildScan" > "WildScan <zone>" > "<zone>: <class>", so a
user can find, hide and inspect e.g. all benches of the park at once. Every
element is its own object (its own `wildscan_instance`); elements that repeat
(trees of one kind, grass tufts, rocks, benches...) are linked duplicates of one
shared mesh, so the file stays small and building stays fast.

Only objects, meshes and collections carrying `wildscan_generated` are ever
removed when a world is rebuilt; the user's own objects stay where they are.
"""

from __future__ import annotations

import hashlib
import time
from typing import Callable

import bpy
import numpy as np

from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION, WorldParams, WorldPlan, plan_world
from . import WORLD_COLLECTION
from .cover import store_cover
from .mesh import (
    GENERATED,
    WORLD_ROOT_PROP,
    WORLD_SEED_PROP,
    mesh_data,
    remove_generated,
    tag_object,
    wildscan_collection,
)

ZONE_PROP = "wildscan_zone"
STAGE_PROP = "wildscan_stage"

Progress = Callable[[str, float], None]


def zone_collection_name(root: str, zone: str) -> str:
    return f"{root} {zone}"


def class_collection_name(zone: str, wildscan_class: str) -> str:
    return f"{zone}: {wildscan_class}"


def build_world(
    seed,
    detail: str = "default",
    progress: Progress | None = None,
    params: WorldParams | None = None,
    collection_name: str = WORLD_COLLECTION,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
) -> WorldPlan:
    """Plan the world for `seed` and realise it in the current scene, replacing what a
    previous build made (and nothing else). `progress(stage, seconds)` after each stage."""
    plan = plan_world(seed, detail, params, progress=progress, vegetation=vegetation, biome=biome)
    realise(plan, collection_name, progress)
    return plan


def _timed(plan: WorldPlan, stage: str, t0: float, progress: Progress | None) -> float:
    now = time.perf_counter()
    plan.timings[stage] = now - t0
    if progress is not None:
        progress(stage, now - t0)
    return now


def realise(
    plan: WorldPlan, collection_name: str = WORLD_COLLECTION, progress: Progress | None = None
) -> dict[str, bpy.types.Object]:
    """Create one object per plan element (linked duplicates of shared meshes)."""
    t0 = time.perf_counter()
    remove_generated(collection_name)
    root = wildscan_collection(collection_name)
    # Recorded on the world itself, so a saved world says what it was built from
    # (the add-on's panel reads these).
    root[WORLD_ROOT_PROP] = True
    root[WORLD_SEED_PROP] = int(plan.seed)
    root["wildscan_detail"] = plan.detail.name
    root["wildscan_vegetation"] = plan.vegetation
    root["wildscan_biome"] = plan.biome
    store_cover(root, plan.cover)
    t0 = _timed(plan, "blender.clear", t0, progress)

    used = {el.proto for el in plan.elements}
    meshes = {
        key: mesh_data(f"{collection_name}.{key}", proto.vertices, proto.faces)
        for key, proto in plan.prototypes.items()
        if key in used
    }
    t0 = _timed(plan, "blender.meshes", t0, progress)

    collections: dict[tuple[str, str], bpy.types.Collection] = {}
    objects: dict[str, bpy.types.Object] = {}
    for el in plan.elements:
        coll = collections.get((el.zone, el.wildscan_class))
        if coll is None:
            zone_coll = wildscan_collection(zone_collection_name(collection_name, el.zone), root)
            coll = wildscan_collection(class_collection_name(el.zone, el.wildscan_class), zone_coll)
            collections[(el.zone, el.wildscan_class)] = coll
        obj = bpy.data.objects.new(el.name, meshes[el.proto])
        obj[GENERATED] = True
        tag_object(obj, el.wildscan_class, el.instance)
        obj[ZONE_PROP] = el.zone
        obj[STAGE_PROP] = el.stage
        obj.location = el.location
        obj.rotation_euler = (0.0, 0.0, el.yaw)
        obj.scale = el.scale
        coll.objects.link(obj)
        objects[el.name] = obj
    t0 = _timed(plan, "blender.objects", t0, progress)
    bpy.context.view_layer.update()
    _timed(plan, "blender.update", t0, progress)
    return objects


def generated_objects(collection_name: str = WORLD_COLLECTION) -> list[bpy.types.Object]:
    root = bpy.data.collections.get(collection_name)
    if root is None:
        return []
    return sorted({o for o in root.all_objects if o.get(GENERATED)}, key=lambda o: o.name)


def scene_hashes(collection_name: str = WORLD_COLLECTION) -> dict[str, str]:
    """SHA-256 per stage (and "all") over every generated object's world-space vertex
    array, faces and tags, read back from Blender."""
    mesh_cache: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    per_stage: dict[str, hashlib._Hash] = {}
    total = hashlib.sha256()
    for obj in generated_objects(collection_name):
        if obj.type != "MESH":
            continue
        mesh = obj.data
        if mesh.name not in mesh_cache:
            co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
            mesh.vertices.foreach_get("co", co)
            idx = np.empty(len(mesh.loops), dtype=np.int32)
            mesh.loops.foreach_get("vertex_index", idx)
            mesh_cache[mesh.name] = (co.reshape(-1, 3).astype(np.float64), idx)
        co, idx = mesh_cache[mesh.name]
        m = np.array(obj.matrix_world, dtype=np.float64)
        world = np.round(co @ m[:3, :3].T + m[:3, 3], 4)
        tags = f"{obj.name}|{obj.get('wildscan_class')}|{obj.get('wildscan_instance')}|{obj.get(ZONE_PROP)}"
        stage = str(obj.get(STAGE_PROP, "user"))
        for h in (per_stage.setdefault(stage, hashlib.sha256()), total):
            h.update(tags.encode())
            h.update(world.tobytes())
            h.update(idx.tobytes())
    out = {stage: h.hexdigest() for stage, h in sorted(per_stage.items())}
    out["all"] = total.hexdigest()
    return out


def scene_counts(collection_name: str = WORLD_COLLECTION) -> dict:
    objs = [o for o in generated_objects(collection_name) if o.type == "MESH"]
    meshes = {o.data.name: o.data for o in objs}
    per_mesh = {}
    for name, mesh in meshes.items():
        sizes = np.empty(len(mesh.polygons), dtype=np.int32)
        mesh.polygons.foreach_get("loop_total", sizes)
        per_mesh[name] = int((sizes - 2).sum())
    tris = sum(per_mesh[o.data.name] for o in objs)
    return {"objects": len(objs), "meshes": len(meshes), "triangles": int(tris)}
