"""The world built in Blender (bpy wheel): tags, collections, shared meshes, scans per zone,
no cracks, rebuilding, determinism read back from the scene."""

from __future__ import annotations

import bpy
import numpy as np
import pytest

from wildscan.app.poses import valid_poses
from wildscan.blender import WORLD_COLLECTION
from wildscan.blender.builder import build_world, generated_objects, scene_counts, scene_hashes
from wildscan.core.classes import BY_ID, WATER_ID, class_by_name
from wildscan.core.placement import Pose
from wildscan.core.rng import stage_rng
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig
from wildscan.core.spatial.leveling import rot_z
from wildscan.core.world import ZONES, WorldParams
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.extract import extract_scene

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

SEED = 1
TWELVE = {c.name for c in BY_ID.values() if 1 <= c.id <= 12}
# What a scan from a zone's first listed pose must return (paper Table I classes).
EXPECTED = {
    "forest": {"trunk", "treetop", "bush"},
    "park": {"table", "bench", "fence"},
    "hills": {"pole", "wire"},
    "lake": {"terrain"},
    "cave": {"terrain"},
    "trail": {"terrain"},
}


@pytest.fixture(scope="module")
def world():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    plan = build_world(SEED, biome="paper")  # the demo's world (app/demo.py BIOME): bare ground
    geometry = extract_scene()  # what any scan of this Blender scene sees
    backend = EmbreeBackend(geometry)
    poses = valid_poses(plan, backend, 3)
    scans = {}
    for zone in ZONES:
        p = poses[zone][0]
        scans[zone] = (
            p,
            run_scan(backend, Pose(p["x"], p["y"], p["yaw"]), SensorConfig(), z_start=p.get("z_start")),
        )
    return {
        "plan": plan,
        "geometry": geometry,
        "backend": backend,
        "poses": poses,
        "scans": scans,
        "hashes": scene_hashes(),
    }


def world_points(pose: dict, result) -> np.ndarray:
    """Leveled points back in the world frame (docs/architecture.md: leveled = Rz(-yaw)(p - centre))."""
    return result.cloud.xyz @ rot_z(np.radians(pose["yaw"])).T + result.placement.optical_centre


# --- the scene --------------------------------------------------------------------------


def test_every_element_is_a_tagged_object_in_zone_and_class_collections(world):
    plan = world["plan"]
    objs = generated_objects()
    assert len(objs) == len(plan.elements)
    root = bpy.data.collections[WORLD_COLLECTION]
    instances = set()
    for obj in objs:
        cls = class_by_name(obj["wildscan_class"]).name
        instances.add(obj["wildscan_instance"])
        coll = obj.users_collection[0]
        zone = obj["wildscan_zone"]
        assert coll.name == f"{zone}: {cls}"
        zone_coll = bpy.data.collections[f"{WORLD_COLLECTION} {zone}"]
        assert coll.name in zone_coll.children and zone_coll.name in root.children
    assert len(instances) == len(objs) and min(instances) >= 1


def test_repeated_elements_are_linked_duplicates(world):
    counts = scene_counts()
    assert counts["objects"] == len(world["plan"].elements)
    assert counts["meshes"] * 20 < counts["objects"]
    tufts = [o for o in generated_objects() if o["wildscan_class"] == "low grass"]
    assert len({o.data.name for o in tufts}) <= 4 < len(tufts)
    assert counts["triangles"] == world["plan"].triangle_count()


def test_extracted_scene_is_the_plan(world):
    plan, geometry = world["plan"], world["geometry"]
    v, f, c, *_ = plan.triangles()
    assert geometry.triangle_count == len(f)
    assert np.array_equal(np.bincount(geometry.class_id, minlength=14), np.bincount(c, minlength=14))


def test_sidecar_poses_exist_for_every_zone(world):
    for zone in ZONES:
        assert len(world["poses"][zone]) == 3, zone
    cave = world["poses"]["cave"][0]
    assert cave["kind"] == "inside cave" and "z_start" in cave


# --- scans per zone ---------------------------------------------------------------------


@pytest.mark.parametrize("zone", ZONES)
def test_scan_from_a_listed_pose_returns_the_zone_classes(world, zone):
    pose, result = world["scans"][zone]
    names = {BY_ID[k].name for k in result.cloud.class_counts()}
    assert EXPECTED[zone] <= names, (zone, names)
    if zone == "forest":
        assert names & {"low grass", "high grass"}


def test_all_twelve_classes_across_the_demo_scans(world):
    seen = set()
    for _, result in world["scans"].values():
        seen |= {BY_ID[k].name for k in result.cloud.class_counts()}
    assert seen == TWELVE


def test_lake_shore_has_no_water_returns_and_a_gap_over_the_water(world):
    plan = world["plan"]
    pose, result = world["scans"]["lake"]
    assert WATER_ID not in result.cloud.class_counts()
    assert result.metadata["water_returns_dropped"] > 1000
    pts = world_points(pose, result)
    over_water = plan.in_water(pts[:, 0], pts[:, 1], -0.1)  # at least 10 cm of water below
    # nothing is seen through the water: no lake bed, no water surface
    assert not np.any(over_water & (pts[:, 2] < plan.water_z + 0.3))
    # and the gap is real: dry ground around it returns plenty
    near = np.hypot(pts[:, 0] - pose["x"], pts[:, 1] - pose["y"]) < 8
    assert (near & ~over_water).sum() > 5000


def test_cave_entrance_scan_sees_under_the_flooring_cover(world):
    plan = world["plan"]
    pose, result = world["scans"]["cave"]
    assert pose["z_start"] < plan.cave_level
    pts = world_points(pose, result)
    cave = plan.layout.cave
    u, v = cave.pit.local(pts[:, 0], pts[:, 1])
    under_roof = (u > cave.roof_u[0]) & (u < cave.roof_u[1]) & (v > cave.roof_v[0]) & (v < cave.roof_v[1])
    below = pts[:, 2] < plan.cave_level - 0.2
    assert (under_roof & below).sum() > 10_000
    # the roof itself is seen from below (flooring, class terrain)
    roof_hits = under_roof & (np.abs(pts[:, 2] - (plan.cave_level - 0.15)) < 0.1)
    assert roof_hits.sum() > 1000
    # under the roof only terrain; out of the ramp's mouth a bush on the surface may show
    assert set(np.unique(result.cloud.label[under_roof])) == {1}
    counts = result.cloud.class_counts()
    assert counts[1] > 0.999 * len(result.cloud)


def test_no_cracks_vertical_rays_hit_everywhere(world):
    plan, backend = world["plan"], world["backend"]
    lay = plan.layout
    rng = stage_rng(0, "test.cracks")
    xy = [rng.uniform(-74.99, 74.99, (150_000, 2))]
    # across the borders: trail edges, shoreline, pit rim, roof edges, the world edge
    along = np.linspace(0, 1, 400)
    path = lay.trail.path
    seg = path[np.minimum((along * (len(path) - 1)).astype(int), len(path) - 2)]
    nxt = path[np.minimum((along * (len(path) - 1)).astype(int) + 1, len(path) - 1)]
    t = nxt - seg
    normal = np.column_stack([-t[:, 1], t[:, 0]]) / np.linalg.norm(t, axis=1, keepdims=True)
    for off in np.linspace(-lay.trail.width / 2 - 0.1, lay.trail.width / 2 + 0.1, 61):
        xy.append(seg + off * normal)
    ang = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    for shape, radii in (
        (lay.lake.basin, np.linspace(0.3, 1.4, 111)),
        (lay.cave.pit, np.linspace(0.5, 1.5, 101)),
    ):
        for r in radii:
            xy.append(np.column_stack(shape.to_world(r * shape.a * np.cos(ang), r * shape.b * np.sin(ang))))
    for u in np.linspace(lay.cave.roof_u[0] - 0.2, lay.cave.roof_u[1] + 0.2, 81):
        v = np.linspace(lay.cave.roof_v[0] - 0.2, lay.cave.roof_v[1] + 0.2, 81)
        xy.append(np.column_stack(lay.cave.pit.to_world(np.full_like(v, u), v)))
    edge = np.linspace(-74.99, 74.99, 2000)
    for c in (-74.99, 74.99):
        xy += [np.column_stack([edge, np.full_like(edge, c)]), np.column_stack([np.full_like(edge, c), edge])]
    xy = np.concatenate(xy)
    origins = np.column_stack([xy, np.full(len(xy), 100.0)])
    down = np.tile([0.0, 0.0, -1.0], (len(xy), 1))
    hits = backend.cast(origins, down, 500.0)
    assert hits.hit.all(), f"{(~hits.hit).sum()} of {len(xy)} vertical rays fell through"
    # the terrain and flooring alone, without anything standing on them, have no crack either
    ground = world["geometry"].subset(world["geometry"].class_id == 1)
    alone = EmbreeBackend(ground).cast(origins, down, 500.0)
    assert alone.hit.all(), f"{(~alone.hit).sum()} rays fell through the terrain"


# --- rebuilding and determinism -----------------------------------------------------------


def test_same_seed_twice_gives_identical_scene(world):
    build_world(SEED, biome="paper")
    assert scene_hashes() == world["hashes"]


def test_one_stage_changed_leaves_the_others_in_the_scene(world):
    build_world(SEED, params=WorldParams().with_stage("rocks", size=(0.5, 3.0)), biome="paper")
    changed = scene_hashes()
    assert changed["rocks"] != world["hashes"]["rocks"]
    for stage, h in world["hashes"].items():
        if stage not in ("rocks", "all"):
            assert changed[stage] == h, stage


def test_rebuilding_replaces_only_what_wildscan_created(world):
    mesh = bpy.data.meshes.new("user_mesh")
    mine = bpy.data.objects.new("user_cube", mesh)
    bpy.context.scene.collection.objects.link(mine)
    inside = bpy.data.objects.new("user_in_wildscan", mesh)
    bpy.data.collections[WORLD_COLLECTION].objects.link(inside)
    in_zone = bpy.data.objects.new("user_in_zone", mesh)
    bpy.data.collections[f"{WORLD_COLLECTION} forest"].objects.link(in_zone)
    plan2 = build_world(SEED + 1)
    for name in ("user_cube", "user_in_wildscan", "user_in_zone"):
        assert name in bpy.data.objects
    assert "user_mesh" in bpy.data.meshes
    assert len(generated_objects()) == len(plan2.elements)
    assert scene_hashes()["all"] != world["hashes"]["all"]
    generated_meshes = [m for m in bpy.data.meshes if m.get("wildscan_generated")]
    assert len(generated_meshes) == len({e.proto for e in plan2.elements})
